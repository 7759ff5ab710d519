"""The agent loop: a LiteLLM model drives the robot through MCP tools until it calls end_task.

The client talks to the robot only through MCP. Each model turn may carry several tool calls,
executed in order; their results go back to the model. When the model stops without calling
end_task it is re-invoked with the task restated (the paper's protocol), up to `max_invocations`;
a task that is never ended is recorded as stopped (a refusal).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from typing import Any, cast

from mcp import Client
from mcp_types import RequestParamsMeta, Tool

from robocog.agent.model import assistant_message, complete, usage
from robocog.agent.model import check_credentials as check_credentials  # re-exported for callers
from robocog.agent.model import warm_up_litellm as warm_up_litellm  # re-exported for callers
from robocog.agent.trace import Trace
from robocog.shared.errors import ModelServiceError, ServerConnectionError
from robocog.shared.protocol import CONTROL_TOOLS, MODEL_META_KEY
from robocog.shared.trace import ModelTurn, Reinvoked, RunFinished, RunStarted, ToolCall, ToolResult, Verdict


@dataclass
class AgentSettings:
    model: str
    max_invocations: int = 10
    max_steps: int = 60
    timeout_s: float = 180.0
    retries: int = 4
    backoff_s: float = 2.0
    api_base: str | None = None
    seed: int | None = None
    temperature: float | None = None
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class EpisodeResult:
    task: str
    ended: bool
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

    @property
    def stopped(self) -> bool:
        return not self.ended


def function_definitions(tools: list[Tool]) -> list[dict[str, Any]]:
    """MCP tool schemas as OpenAI / LiteLLM function definitions (control tools left out)."""
    return [
        {
            "type": "function",
            "function": {
                "name": t.name,
                "description": t.description or t.title or t.name,
                "parameters": t.input_schema or {"type": "object", "properties": {}},
            },
        }
        for t in tools
        if t.name not in CONTROL_TOOLS
    ]


def reminder(task: str) -> str:
    return (
        f"The task is not finished: you have not called end_task yet. The task is: {task}\n"
        "Act with your tools to complete it, or call end_task with an honest status and a summary."
    )


def _text(result: Any) -> str:
    parts = [getattr(block, "text", "") for block in result.content]
    return "\n".join(p for p in parts if p) or json.dumps(result.structured_content)


async def run_episode(
    client: Client,
    task: str,
    settings: AgentSettings,
    trace: Trace,
    *,
    system_prompt: str,
    tools: list[Tool],
    server_label: str = "",
) -> EpisodeResult:
    """Run one task to its end (or to the invocation limit) and return how it went."""
    started = time.monotonic()
    definitions = function_definitions(tools)
    names = {d["function"]["name"] for d in definitions}
    trace.emit(
        RunStarted(
            t=trace.now(), task=task, model=settings.model, server=server_label, tools=sorted(names), seed=settings.seed
        )
    )
    messages: list[dict[str, Any]] = [{"role": "system", "content": system_prompt}, {"role": "user", "content": task}]
    ended = False
    believed: bool | None = None
    summary: str | None = None
    tool_calls = tokens_in = tokens_out = 0
    cost: float | None = None
    llm_latency = 0.0
    invocation = 0
    error: str | None = None
    try:
        while invocation < settings.max_invocations and not ended:
            invocation += 1
            if invocation > 1:
                trace.emit(Reinvoked(t=trace.now(), invocation=invocation, reason="the model stopped without end_task"))
                messages.append({"role": "user", "content": reminder(task)})
            for step in range(1, settings.max_steps + 1):
                t0 = time.monotonic()
                response = await complete(settings, messages, definitions)
                latency = time.monotonic() - t0
                llm_latency += latency
                message = assistant_message(response)
                messages.append(message)
                t_in, t_out, c = usage(response)
                tokens_in, tokens_out = tokens_in + t_in, tokens_out + t_out
                if c is not None:
                    cost = (cost or 0.0) + c
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
                    )
                )
                calls = message.get("tool_calls") or []
                if not calls:
                    break
                for call in calls:
                    tool_calls += 1
                    done, content = await _execute(client, call, names, settings, trace, invocation)
                    messages.append({"role": "tool", "tool_call_id": call["id"], "content": content})
                    if done is not None:
                        ended, believed, summary = True, done[0], done[1]
                if ended:
                    break
    except (ModelServiceError, ServerConnectionError) as exc:
        error = str(exc)
    result = EpisodeResult(
        task=task,
        ended=ended,
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
    )
    return result


async def _execute(
    client: Client, call: dict[str, Any], names: set[str], settings: AgentSettings, trace: Trace, invocation: int
) -> tuple[tuple[bool, str] | None, str]:
    """Run one tool call; returns ((believed success, summary) if it ended the task, text for the model)."""
    name = call["function"]["name"]
    raw = call["function"].get("arguments") or "{}"
    arguments: dict[str, Any] | None
    problem: str | None = None
    try:
        parsed = json.loads(raw) if raw.strip() else {}
        arguments = parsed if isinstance(parsed, dict) else None
        if arguments is None:
            problem = f"Error: the arguments of {name} must be a JSON object, not {type(parsed).__name__}."
    except json.JSONDecodeError as exc:
        arguments = None
        problem = f"Error: the arguments of {name} are not a valid JSON object ({exc})."
    trace.emit(
        ToolCall(t=trace.now(), invocation=invocation, id=call["id"], name=name, arguments=arguments, raw_arguments=raw)
    )
    if problem is not None:
        problem += " Call the tool again with arguments that match its schema."
    elif name not in names:
        problem = f"Error: there is no tool called {name!r}. The tools are: {', '.join(sorted(names))}."
    if problem is not None or arguments is None:  # rejected here: the server never sees the call
        content = problem or ""
        trace.emit(
            ToolResult(
                t=trace.now(),
                invocation=invocation,
                id=call["id"],
                name=name,
                is_error=True,
                content=content,
                latency_s=0.0,
            )
        )
        return None, content
    t0 = time.monotonic()
    try:
        result = await client.call_tool(
            name,
            arguments,
            read_timeout_seconds=settings.timeout_s,
            meta=cast(RequestParamsMeta, {MODEL_META_KEY: settings.model}),
        )
    except Exception as exc:  # the server or the transport failed: the run cannot go on
        raise ServerConnectionError(f"the robot server failed on {name}: {exc}") from exc
    content = _text(result)
    structured = result.structured_content if isinstance(result.structured_content, dict) else None
    trace.emit(
        ToolResult(
            t=trace.now(),
            invocation=invocation,
            id=call["id"],
            name=name,
            is_error=bool(result.is_error),
            content=content,
            structured=structured,
            latency_s=round(time.monotonic() - t0, 4),
        )
    )
    if name == "end_task" and not result.is_error:
        return (arguments.get("status") == "success", str(arguments.get("summary", ""))), content
    return None, content


def finish(trace: Trace, result: EpisodeResult, verdict: Verdict | None) -> RunFinished:
    """Emit the verdict (when known) and the run's closing event."""
    if verdict is not None:
        trace.emit(verdict)
    event = RunFinished(
        t=trace.now(),
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
