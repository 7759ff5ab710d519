"""What a tool is: one unit holding its name, title, annotations, arguments and behaviour.

A tool's behaviour is a plain function `run(robot, **arguments) -> Result`: `robot` is the
`RobotSession` (its world, memory, scratchpad and episode), the other parameters are the tool's
arguments, typed with `Annotated[..., Field(description=...)]` so that the MCP input schema explains
itself (a text argument also has a `max_length` from `robocog.shared.limits` and an `at_most` check,
so the SDK refuses an oversize value, with a message saying what to do, before any tool code runs;
the description lists the limits), and the return annotation is the pydantic result model (the MCP output schema). The
function's docstring is the tool's description, unless the `Tool` is given one (a description
built from constants, so that numbers are written down once). A failure the model could have avoided is a result
with `status="failure"`, an error code and a message to act on; a `ValueError` raised by `run` is
bad input, reported to the caller as a tool error with its message.

The MCP app registers every `Tool` of `robocog.server.tools` generically; nothing here imports the
MCP server, so a tool is tested by calling `run` with a session.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Literal, TypeVar

from mcp_types import ToolAnnotations
from pydantic import BaseModel, BeforeValidator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError

R = TypeVar("R", bound=BaseModel)

#: Called with (done, total, message) while a long action runs; the app turns it into MCP progress.
ProgressFn = Callable[[float, float, str], None]

READ_ONLY = ToolAnnotations(read_only_hint=True, open_world_hint=False)
ACTION = ToolAnnotations(read_only_hint=False, destructive_hint=False, idempotent_hint=False, open_world_hint=False)
IDEMPOTENT_ACTION = ToolAnnotations(
    read_only_hint=False, destructive_hint=False, idempotent_hint=True, open_world_hint=False
)
DESTRUCTIVE = ToolAnnotations(read_only_hint=False, destructive_hint=True, open_world_hint=False)
CONTROL = ToolAnnotations(read_only_hint=False, open_world_hint=False)


def at_most(limit: int, advice: str) -> BeforeValidator:
    """The check of a text argument of at most `limit` characters (its Field's `max_length` too): run
    before any other validation, it refuses a longer value at once with a message the model can act on
    (pydantic's own says neither how long the value was nor what to do)."""

    def check(value: object) -> object:
        if isinstance(value, str) and len(value) > limit:
            raise PydanticCustomError(
                "text_too_long",
                "too long: {length} characters, at most {limit} are accepted; {advice}",
                {"length": len(value), "limit": limit, "advice": advice},
            )
        return value

    return BeforeValidator(check)


def max_length(annotation: object) -> int | None:
    """The `max_length` of an argument's `Annotated[..., Field(max_length=...)]`, if it has one."""
    for meta in getattr(annotation, "__metadata__", ()):
        if isinstance(meta, FieldInfo):
            for constraint in meta.metadata:  # annotated_types.MaxLen, as pydantic records it
                limit = getattr(constraint, "max_length", None)
                if isinstance(limit, int):
                    return limit
    return None


@dataclass(frozen=True)
class Caller:
    """Who is calling, for the duration of one call: a progress sink, the driving model's label, and
    whether the call is one of the episode's (not when a client watches a robot another drives)."""

    progress: ProgressFn | None = None
    model: str | None = None
    counts: bool = True

    def report(self, done: float, total: float, message: str) -> None:
        if self.progress is not None:
            self.progress(done, total, message)


@dataclass(frozen=True, eq=False)
class Tool(Generic[R]):
    """One tool: its MCP metadata and the function that does the work (compared by identity)."""

    name: str
    title: str
    annotations: ToolAnnotations
    run: Callable[..., R]
    #: "robot": offered to models in every profile; "control": the eval profile's harness controls;
    #: "app": for the robot app alone (`robocog.server.wiring.ui`), hidden from models.
    kind: Literal["robot", "control", "app"] = "robot"
    #: The description when it is not `run`'s docstring.
    doc: str | None = None
    #: A successful call can change the world (the robot, an object): subscribers of the world's
    #: resources are told after it.
    changes_world: bool = False
    #: The tool ends the episode (end_task): called again right after with the same arguments, it is a
    #: retry of that end, not the first call of a new episode.
    ends_episode: bool = False

    @property
    def description(self) -> str:
        """The docstring (or `doc`), then the limits of the text arguments, from their schemas."""
        text = inspect.cleandoc(self.doc or self.run.__doc__ or "")
        limits = self.text_limits
        if limits:
            text += "\n\nLimits: " + "; ".join(f"{name} at most {n} characters" for name, n in limits.items()) + "."
        return text

    @property
    def text_limits(self) -> dict[str, int]:
        """The most characters each bounded text argument accepts, by argument name."""
        limits = {p.name: max_length(p.annotation) for p in self.parameters}
        return {name: n for name, n in limits.items() if n is not None}

    @property
    def counts_as_episode_call(self) -> bool:
        """Robot tools are the episode's tool calls; a harness's controls and the app's reads are not."""
        return self.kind == "robot"

    @property
    def parameters(self) -> list[inspect.Parameter]:
        """The tool's arguments: `run`'s parameters after the session, their annotations resolved."""
        _, *arguments = inspect.signature(self.run).parameters.values()
        return [p.replace(annotation=self._resolve(p.annotation)) for p in arguments]

    @property
    def result_type(self) -> type[R]:
        result: type[R] = self._resolve(inspect.signature(self.run).return_annotation)
        return result

    def _resolve(self, annotation: object) -> Any:
        """An annotation written as a string (`from __future__ import annotations`) as the type it names.
        The session parameter is never resolved: tool modules import its type only for type checking."""
        if isinstance(annotation, str):
            return eval(annotation, self.run.__globals__)
        return annotation
