"""The agent loop: a LiteLLM model drives the robot through MCP tools until it calls end_task.

The client talks to the robot only through MCP. Each model turn may carry several tool calls,
executed in order; their results go back to the model. When the model stops without calling
end_task it is re-invoked with the task restated (the paper's protocol), up to `max_invocations`;
a task that is never ended is recorded as stopped (a refusal); a failing model service or server is
an error, never a refusal. What the messages say is the protocol's (see `robocog.agent.study_protocols`).
A picture in a tool result goes to the model only when it takes images (`AgentSettings.vision`), in a
user message after the turn's tool messages (see `model.image_message`); the trace keeps it as a file.
"""

from __future__ import annotations

import base64
import json
import time
from dataclasses import dataclass
from typing import Any, Literal, cast

from mcp_types import RequestParamsMeta, Tool

from robocog.agent.client.model import (
    IMAGE_OMITTED,
    assistant_message,
    complete,
    finish_reason,
    image_message,
    usage,
)
from robocog.agent.client.model_errors import Retries
from robocog.agent.client.protocols import McpClient
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.slips import decode_arguments, text_tool_calls
from robocog.agent.client.trace_sinks import Trace
from robocog.agent.study_protocols import DESCRIPTION_URI, PROTOCOLS, EvalProtocol
from robocog.shared.errors import MemoryStorageError, ModelServiceError, ServerConnectionError
from robocog.shared.perturbations import PERTURBATION_META_KEY, PerturbationEvent
from robocog.shared.protocol import FLEET_FULL, FURNITURE_TOOLS, MEMORY_FAILED, MODEL_META_KEY
from robocog.shared.provenance import function_definition, offered
from robocog.shared.trace import (
    ModelTurn,
    Perturbed,
    Reinvoked,
    RunFinished,
    RunStarted,
    ToolCall,
    ToolResult,
    Verdict,
)

Outcome = Literal["ended", "stopped", "error"]


@dataclass
class EpisodeResult:
    """How one task attempt went. `outcome`: the agent called end_task (`ended`), never did within
    the invocations (`stopped`: the paper's refusal), or the model service or the server failed
    (`error`, never a refusal)."""

    task: str
    outcome: Outcome
    believed_success: bool | None
    invocations: int
    tool_calls: int
    tokens_in: int
    tokens_out: int
    cost: float | None
    llm_latency_s: float
    wall_s: float
    summary: str | None = None
    error: str | None = None
    text_tool_calls: int = 0  # tool calls the model wrote as text, not run (`robocog.agent.client.slips`)

    @property
    def ended(self) -> bool:
        return self.outcome == "ended"

    @property
    def stopped(self) -> bool:
        return self.outcome == "stopped"


def function_definitions(tools: list[Tool], *, vision: bool = False, furniture: bool = True) -> list[dict[str, Any]]:
    """MCP tool schemas as OpenAI / LiteLLM function definitions: never the controls, the camera only
    with `vision` (a text-only model would get nothing from it), open and close only with `furniture`
    (the paper's protocol offers its eight tools)."""
    return [
        function_definition(t.name, t.description or t.title, t.input_schema)
        for t in tools
        if offered(t.name, vision=vision, furniture=furniture)
    ]


#: A picture from a tool result: (tool name, MIME type, base64 data).
Picture = tuple[str, str, str]


def _text(result: Any) -> str:
    parts = [getattr(block, "text", "") for block in result.content]
    return "\n".join(p for p in parts if p) or json.dumps(result.structured_content)


def _pictures(result: Any) -> list[tuple[str, str]]:
    """The image content blocks of a tool result, as (MIME type, base64 data)."""
    return [(block.mime_type, block.data) for block in result.content if getattr(block, "type", None) == "image"]


async def run_episode(
    client: McpClient,
    task: str,
    settings: AgentSettings,
    trace: Trace,
    *,
    system_prompt: str,
    tools: list[Tool],
    server_label: str = "",
    protocol: EvalProtocol = PROTOCOLS["robocog"],
    conversation: list[dict[str, Any]] | None = None,
    furniture: bool | None = None,
) -> EpisodeResult:
    """Run one task to its end (or to the invocation limit) and return how it went.

    `conversation` is the message list to continue (the paper's protocol runs T2 after T1 in one
    conversation); it is extended in place, and an empty one starts with the system prompt.
    `furniture`: whether to offer open and close, when the caller has asked the world already (the
    harness, for the attempt's provenance); None asks it (`world_has_furniture`).
    """
    started = time.monotonic()
    if furniture is None:
        furniture = await world_has_furniture(client, tools)
    furniture = protocol.offers_furniture and furniture
    definitions = function_definitions(tools, vision=settings.vision and protocol.offers_camera, furniture=furniture)
    names = {d["function"]["name"] for d in definitions}
    trace.emit(
        RunStarted(
            t=trace.now(),
            task=task,
            model=settings.model,
            server=server_label,
            tools=sorted(names),
            seed=settings.seed,
            protocol=protocol.name,
        )
    )
    messages = conversation if conversation is not None else []
    if not messages:
        messages.append({"role": "system", "content": system_prompt})
    ended = False
    believed: bool | None = None
    summary: str | None = None
    tool_calls = tokens_in = tokens_out = 0
    cost: float | None = None
    llm_latency = 0.0
    invocation = 0
    error: str | None = None
    written_as_text = 0
    try:
        while invocation < settings.max_invocations and not ended:
            invocation += 1
            description = await _describe(client) if protocol.describe_environment else None
            if invocation == 1:
                messages.append({"role": "user", "content": protocol.first_message(task, description)})
            else:
                trace.emit(Reinvoked(t=trace.now(), invocation=invocation, reason="the model stopped without end_task"))
                messages.append({"role": "user", "content": protocol.reinvocation_message(task, description)})
            for step in range(1, settings.max_steps + 1):
                t0, retried = time.monotonic(), Retries()
                response = await complete(settings, messages, definitions, retried)
                latency = time.monotonic() - t0
                llm_latency += latency
                message = assistant_message(response)
                messages.append(_sendable(message))
                t_in, t_out, c = usage(response)
                tokens_in, tokens_out = tokens_in + t_in, tokens_out + t_out
                if c is not None:
                    cost = (cost or 0.0) + c
                as_text = text_tool_calls(message.get("content"), names)
                written_as_text += as_text
                trace.emit(
                    ModelTurn(
                        t=trace.now(),
                        invocation=invocation,
                        step=step,
                        message=message,
                        latency_s=round(latency, 4),
                        tokens_in=t_in,
                        tokens_out=t_out,
                        cost=c,
                        finish_reason=finish_reason(response),
                        text_tool_calls=as_text,
                        retries=retried.count,
                        retry_s=round(retried.seconds, 4),
                    )
                )
                calls = message.get("tool_calls") or []
                if not calls:
                    break
                pictures: list[Picture] = []
                for call in calls:
                    if ended:  # after end_task nothing more runs: it would begin the next episode
                        content = "Not run: the task was ended with end_task."
                    else:
                        tool_calls += 1
                        done, content, shown = await _execute(client, call, names, settings, trace, invocation)
                        pictures += shown
                        if done is not None:
                            ended, believed, summary = True, done[0], done[1]
                    messages.append({"role": "tool", "tool_call_id": call["id"], "content": content})
                if pictures:  # after every tool message of the turn: they must follow the assistant's calls
                    messages.append(image_message(pictures))
                if ended:
                    break
    except (ModelServiceError, ServerConnectionError) as exc:
        error = f"{type(exc).__name__}: {exc}"
    outcome: Outcome = "error" if error is not None else ("ended" if ended else "stopped")
    return EpisodeResult(
        task=task,
        outcome=outcome,
        believed_success=believed,
        invocations=invocation,
        tool_calls=tool_calls,
        tokens_in=tokens_in,
        tokens_out=tokens_out,
        cost=cost,
        llm_latency_s=round(llm_latency, 4),
        wall_s=round(time.monotonic() - started, 4),
        summary=summary,
        error=error,
        text_tool_calls=written_as_text,
    )


#: The ground truth resource: its `furniture` says whether the world has anything that opens.
STATE_URI = "robocog://world/state"


async def world_has_furniture(client: McpClient, tools: list[Tool], *, known: bool | None = None) -> bool:
    """Whether to offer open and close: only in a world with furniture that opens (its ground truth
    lists some), so a model in a world without (the paper's household, the robocog-v1 suite) is offered
    what it was before they existed. A server whose state cannot be read keeps what it publishes.
    `known`: what the caller learnt of this world already (the answer of the reset that made it), in
    place of reading its state."""
    if not any(t.name in FURNITURE_TOOLS for t in tools):
        return False
    if known is not None:
        return known
    try:
        result = await client.read_resource(STATE_URI)
        state = json.loads("".join(getattr(c, "text", "") for c in result.contents))
    except Exception:
        return True
    return not isinstance(state, dict) or bool(state.get("furniture"))


async def _describe(client: McpClient) -> str:
    """The environment description the paper's task message carries (a resource: not a tool call)."""
    try:
        result = await client.read_resource(DESCRIPTION_URI)
    except Exception as exc:
        raise ServerConnectionError(f"cannot read {DESCRIPTION_URI}: {exc}") from exc
    return "\n".join(getattr(c, "text", "") for c in result.contents).strip()


def _sendable(message: dict[str, Any]) -> dict[str, Any]:
    """The assistant message as the conversation keeps it: double-encoded arguments as the object
    they hold (the call ran so), other tool-call arguments that are not a JSON object as "{}" (the
    trace keeps them verbatim). Providers re-parse the history's arguments, and one that cannot
    (Ollama's route) would fail every later call on the model's old mistake."""
    calls = message.get("tool_calls")
    if not calls:
        return message
    fixed = []
    for call in calls:
        raw = call["function"].get("arguments") or "{}"
        arguments, slip, _ = decode_arguments(raw)
        if arguments is not None and slip is None and raw.strip():
            fixed.append(call)
        else:
            sent = json.dumps(arguments) if arguments is not None else "{}"
            fixed.append({**call, "function": {**call["function"], "arguments": sent}})
    return {**message, "tool_calls": fixed}


async def _execute(
    client: McpClient, call: dict[str, Any], names: set[str], settings: AgentSettings, trace: Trace, invocation: int
) -> tuple[tuple[bool, str] | None, str, list[Picture]]:
    """Run one tool call; returns ((believed success, summary) if it ended the task, text for the model,
    the pictures to show it: none unless it takes images, when the text says so instead)."""
    name = call["function"]["name"]
    raw = call["function"].get("arguments") or "{}"
    arguments, slip, wrong = decode_arguments(raw)  # double-encoded arguments run as the model meant
    trace.emit(
        ToolCall(
            t=trace.now(),
            invocation=invocation,
            id=call["id"],
            name=name,
            arguments=arguments,
            raw_arguments=raw,
            slip=slip,
        )
    )
    problem: str | None = None
    if wrong is not None:
        problem = f"Error: the arguments of {name} {wrong}. Call the tool again with arguments that match its schema."
    elif name not in names:
        problem = f"Error: there is no tool called {name!r}. The tools are: {', '.join(sorted(names))}."
    t0 = time.monotonic()
    is_error, structured = True, None
    pictures: list[Picture] = []
    references: list[str] = []
    rejected = problem is not None or arguments is None
    perturbations: list[PerturbationEvent] = []
    if rejected:  # rejected here: the server never sees the call
        content = problem or ""
    else:
        try:
            result = await client.call_tool(
                name,
                arguments,
                read_timeout_seconds=settings.timeout_s,
                meta=cast(RequestParamsMeta, {MODEL_META_KEY: settings.model}),
            )
        except Exception as exc:  # the server or the transport failed: the run cannot go on
            raise ServerConnectionError(f"the robot server failed on {name}: {exc}") from exc
        content, is_error = _text(result), bool(result.is_error)
        if is_error and FLEET_FULL in content:  # the server has no robot for this client: not the model's doing
            raise ServerConnectionError(f"the robot server refused {name}: {content}")
        structured = result.structured_content if isinstance(result.structured_content, dict) else None
        perturbations = [
            PerturbationEvent.model_validate(e) for e in (result.meta or {}).get(PERTURBATION_META_KEY, [])
        ]
        for mime_type, data in _pictures(result):
            references.append(trace.save_image(base64.b64decode(data), tool=name, mime_type=mime_type))
            if settings.vision:
                pictures.append((name, mime_type, data))
            else:
                content += "\n" + IMAGE_OMITTED
    trace.emit(
        ToolResult(
            t=trace.now(),
            invocation=invocation,
            id=call["id"],
            name=name,
            is_error=is_error,
            content=content,
            structured=structured,
            latency_s=0.0 if rejected else round(time.monotonic() - t0, 4),
            images=references,
            images_sent=bool(pictures),
        )
    )
    for happened in perturbations:
        trace.emit(Perturbed(t=trace.now(), invocation=invocation, id=call["id"], event=happened))
    if is_error and not rejected and MEMORY_FAILED in content:  # its storage failed (disk full, read-only)
        raise MemoryStorageError(f"the robot server failed on {name}: {content}")  # no retry would help
    if name == "end_task" and arguments is not None and not is_error:
        return (arguments.get("status") == "success", str(arguments.get("summary", ""))), content, pictures
    return None, content, pictures


def finish(trace: Trace, result: EpisodeResult, verdict: Verdict | None) -> RunFinished:
    """Emit the verdict (when known) and the run's closing event."""
    if verdict is not None:
        trace.emit(verdict)
    event = RunFinished(
        t=trace.now(),
        outcome=result.outcome,
        ended=result.ended,
        stopped=result.stopped,
        believed_success=result.believed_success,
        true_success=verdict.success if verdict is not None else None,
        invocations=result.invocations,
        tool_calls=result.tool_calls,
        tokens_in=result.tokens_in,
        tokens_out=result.tokens_out,
        cost=result.cost,
        llm_latency_s=result.llm_latency_s,
        wall_s=result.wall_s,
        error=result.error,
    )
    trace.emit(event)
    return event
