"""The run trace as data: one event per line of a JSONL file, each a pydantic model.

A trace records everything an agent run did: the task, every model turn (with tokens, cost and
latency when known), every tool call with its arguments and result, re-invocations, and how the
run ended. `robocog run --trace FILE.jsonl` writes it; `replay/FILE.jsonl` replays its model turns.
A picture a tool returned (look's camera image) is a file in `FILE.images/`, which the event names.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, TypeAdapter

from robocog.shared.perturbations import PerturbationEvent

#: 3: a tool result's pictures (`ToolResult.images`, files next to the trace).
#: 4: perturbations (`Perturbed`, after the result of the call during which each happened).
#: 5: a model's slips: a turn's `finish_reason` and `text_tool_calls`, a tool call's `slip`.
TRACE_VERSION = 5


class _Event(BaseModel):
    t: float = Field(description="seconds since the run started")


class RunStarted(_Event):
    type: Literal["run_started"] = "run_started"
    version: int = TRACE_VERSION
    task: str
    model: str
    server: str = Field(description="how the server was reached: the command line or the URL")
    tools: list[str]
    seed: int | None = None
    protocol: str = Field(default="robocog", description="the evaluation protocol: 'paper' or 'robocog'")


class ModelTurn(_Event):
    """One model response: the assistant message as it was added to the conversation."""

    type: Literal["model_turn"] = "model_turn"
    invocation: int
    step: int
    message: dict[str, Any] = Field(description="the assistant message (role, content, tool_calls)")
    latency_s: float
    tokens_in: int = 0
    tokens_out: int = 0
    cost: float | None = None
    finish_reason: str | None = Field(
        default=None,
        description='why the model stopped writing the turn, as the provider said ("stop", "tool_calls", "length": '
        "cut at the token limit); absent when it said nothing",
        exclude_if=lambda v: v is None,
    )
    text_tool_calls: int = Field(
        default=0,
        description="tool calls the turn wrote as text in its content, not run (robocog.agent.client.slips)",
        exclude_if=lambda v: v == 0,
    )
    retries: int = Field(
        default=0, description="failed attempts of the turn's model call that were retried", exclude_if=lambda v: v == 0
    )
    retry_s: float = Field(
        default=0.0,
        description="seconds those attempts and the waits after them took (part of latency_s)",
        exclude_if=lambda v: v == 0,
    )


class ToolCall(_Event):
    type: Literal["tool_call"] = "tool_call"
    invocation: int
    id: str
    name: str
    arguments: dict[str, Any] | None = Field(description="parsed arguments, None if they were not valid JSON")
    raw_arguments: str
    slip: Literal["double_encoded"] | None = Field(
        default=None,
        description="how the arguments were written amiss and read as meant: `double_encoded`, a JSON string "
        "holding the JSON object (decoded and run)",
        exclude_if=lambda v: v is None,
    )


class ToolResult(_Event):
    type: Literal["tool_result"] = "tool_result"
    invocation: int
    id: str
    name: str
    is_error: bool
    content: str = Field(description="the text the model was given")
    structured: dict[str, Any] | None = None
    latency_s: float
    images: list[str] = Field(
        default=[],
        description="the pictures the result carried, as files next to the trace: paths relative to the trace's "
        "folder (TRACE.images/NNNN-TOOL.png), never the bytes",
    )
    images_sent: bool = Field(default=False, description="the pictures went to the model (a vision run)")


class Perturbed(_Event):
    """Something went wrong in the world during a tool call (`robocog.shared.perturbations`): a slip,
    an object moved, a container closed, a corridor blocked (or clear again); written after that
    call's result, whether the result said so (`announced`) or not."""

    type: Literal["perturbation"] = "perturbation"
    invocation: int
    id: str = Field(description="the tool call during which it happened")
    event: PerturbationEvent


class Reinvoked(_Event):
    type: Literal["reinvoked"] = "reinvoked"
    invocation: int
    reason: str


class Verdict(_Event):
    type: Literal["verdict"] = "verdict"
    task_id: str
    success: bool
    reason: str


class RunFinished(_Event):
    type: Literal["run_finished"] = "run_finished"
    outcome: Literal["ended", "stopped", "error"] = Field(
        description="end_task was called; never called (a refusal); or the model service or server failed"
    )
    ended: bool = Field(description="the agent called end_task")
    stopped: bool = Field(description="the agent never ended the task within the invocations (a refusal)")
    believed_success: bool | None = None
    true_success: bool | None = None
    invocations: int
    tool_calls: int
    tokens_in: int
    tokens_out: int
    cost: float | None = None
    llm_latency_s: float
    wall_s: float
    error: str | None = None


TraceEvent = Annotated[
    RunStarted | ModelTurn | ToolCall | ToolResult | Perturbed | Reinvoked | Verdict | RunFinished,
    Field(discriminator="type"),
]
_adapter: TypeAdapter[TraceEvent] = TypeAdapter(TraceEvent)


def parse_event(line: str) -> TraceEvent:
    """One JSONL line back into its event model."""
    return _adapter.validate_json(line)


def read_trace(path: Path) -> list[TraceEvent]:
    """Every event of a trace file."""
    return [parse_event(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def dump_event(event: BaseModel) -> str:
    """One event as a JSONL line (compact JSON, UTF-8 as it is; pydantic's serializer: a quarter of
    the CPU of dumping it to Python and encoding that, and an attempt writes about 57 events)."""
    return event.model_dump_json()
