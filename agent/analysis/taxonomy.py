"""The error taxonomy of one attempt, computed from its trace alone (deterministic, no model asked).

In the spirit of the Embodied Agent Interface (NeurIPS 2024), each category counts what the trace
shows; a tool call counts once in every category it shows (a `place` on an unknown location with
an empty hand is both a hallucination and an affordance error):

- `parse`: a malformed tool call: arguments that are not a JSON object, a tool that was not offered,
  or arguments the tool's schema refused (the server's "Invalid arguments for TOOL: ..."); and the
  slips the client reads where the intent is clear (`robocog.agent.client.slips`): arguments
  double-encoded (decoded and run, so the call counts in the other categories too) and each tool
  call written as text in a turn's content (not run).
- `hallucination`: a robot action named an object, location or position that is not in the scene:
  the server answered `unknown_object`, `unknown_location` or `unknown_position`; or, where the
  server failed before it resolved the names (place with an empty hand), an argument is none of
  the names the trace's look_around results (or the scene, when given) list.
- `affordance`: an action the world cannot afford in its state: grab while holding
  (`already_holding`), place with an empty hand (`nothing_held`), grab a non-graspable object
  (`not_graspable`), an object the arm cannot reach from where the robot stands (`out_of_reach`
  without a move_to hint), a place on an occupied position whose occupant is never moved later.
- `wrong_order`: an action whose precondition a later action of the plan should have met first:
  a grab or place before the move_to to its location (`not_at_location`, or `out_of_reach` with
  the server's "move_to(...) first" hint), a grab or place into a closed container before the open
  it needs (`out_of_reach` naming the `container`, or with "open(...) first"), or a place on a
  position held by an object the agent grabs later in the attempt (it had to move that object, or
  park it, first: the Blocksworld "non-constructive" move done in the wrong order).
- `missing_step`: the agent ended the task (end_task accepted) on a feasible task whose goal the
  ground truth found unmet: a step of the plan was never done. (On an infeasible task a claimed
  success is scored as honesty, not here.)
- `additional_step`: successful robot actions (move_to, grab, place) beyond the planner's
  `optimal_steps`; only when the optimum is known (the key is absent otherwise).

Failures of the world rather than the plan (`no_path`, `place_failed`, a grab of an object a
perturbation moved since the agent last looked around: `moved_unseen`) and errors of the service
are counted in no category. Categories absent from a result were not measurable.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.agent.analysis import recovery
from robocog.shared.evaluation import AttemptRow
from robocog.shared.names import name_key
from robocog.shared.trace import (
    ModelTurn,
    Perturbed,
    RunFinished,
    RunStarted,
    ToolCall,
    ToolResult,
    TraceEvent,
    Verdict,
    read_trace,
)

if TYPE_CHECKING:
    pass

#: Every category, in the report's order.
CATEGORIES = ("parse", "hallucination", "affordance", "wrong_order", "missing_step", "additional_step")
#: The tools that move the robot or change the world, as `optimal_steps` counts them; efficiency and
#: additional steps count these.
ROBOT_ACTIONS = frozenset({"move_to", "grab", "place", "open", "close"})

_HALLUCINATION_CODES = frozenset({"unknown_object", "unknown_location", "unknown_position"})
_AFFORDANCE_CODES = frozenset({"already_holding", "nothing_held", "not_graspable"})
#: Failures the server reports before it has resolved every name of the call.
_UNCHECKED_NAMES = frozenset({"nothing_held", None})
_INVALID_ARGUMENTS = "Invalid arguments for "
_NO_SUCH_TOOL = "Error: there is no tool called"
_MOVE_HINT = "move_to("
_CLOSED = "which is closed"
_OPEN_HINT = "open("
_OCCUPIED_BY = re.compile(r"occupied by the (.+?)\.")


def normalise(name: str) -> str:
    """Names as the server compares them (`robocog.shared.names.name_key`, every article kept)."""
    return name_key(name, articles="keep")


@dataclass
class SceneNames:
    """The names a scene has: locations, objects, and each location's place positions (normalised)."""

    locations: set[str] = field(default_factory=set)
    objects: set[str] = field(default_factory=set)
    positions: dict[str, set[str]] = field(default_factory=dict)

    def add_look_around(self, data: dict[str, Any]) -> None:
        """The names a look_around result lists (its locations, objects, positions, the held object)."""
        if data.get("holding"):
            self.objects.add(normalise(str(data["holding"])))
        for view in data.get("locations") or []:
            loc = normalise(str(view.get("name", "")))
            self.locations.add(loc)
            self.objects.update(normalise(str(o)) for o in view.get("objects") or [])
            mine = self.positions.setdefault(loc, set())
            mine.update(normalise(str(p.get("name", ""))) for p in view.get("place_positions") or [])

    def unknown(self, tool: str, arguments: dict[str, Any]) -> bool:
        """An argument of a robot action that is none of the names known (a kind with no names known
        is not judged)."""
        location = arguments.get("location")
        if isinstance(location, str) and self.locations and normalise(location) not in self.locations:
            return True
        thing = arguments.get("object")
        if tool == "grab" and isinstance(thing, str) and self.objects and normalise(thing) not in self.objects:
            return True
        position = arguments.get("position")
        known = self.positions.get(normalise(location), set()) if isinstance(location, str) else set()
        return tool == "place" and isinstance(position, str) and bool(known) and normalise(position) not in known


@dataclass(frozen=True)
class _Call:
    call: ToolCall
    result: ToolResult | None

    @property
    def data(self) -> dict[str, Any]:
        return (self.result.structured or {}) if self.result is not None else {}

    @property
    def failed(self) -> bool:
        return self.result is not None and (self.result.is_error or self.data.get("status") == "failure")

    @property
    def executed(self) -> bool:
        """The server ran it (it answered with a structured result)."""
        return self.result is not None and self.result.structured is not None


def _calls(events: Sequence[TraceEvent]) -> list[_Call]:
    """Each tool call with its result (the result follows its call; ids may repeat across turns)."""
    calls: list[_Call] = []
    open_: dict[str, int] = {}
    for e in events:
        if isinstance(e, ToolCall):
            open_[e.id] = len(calls)
            calls.append(_Call(e, None))
        elif isinstance(e, ToolResult) and e.id in open_:
            i = open_.pop(e.id)
            calls[i] = _Call(calls[i].call, e)
    return calls


def moved_unseen(events: Sequence[TraceEvent]) -> set[int]:
    """The indices (in call order) of the robot actions a perturbation foiled before the agent could
    know of it: since the agent last looked around, a grab of an object a perturbation moved (a slip, a
    moved object), a place with the hand a slip emptied, a grab from or a place into a container a
    perturbation closed that its result says is closed (until the agent opens it again). Where such an
    action fails, the world changed, not the agent's order of actions."""
    moved: set[str] = set()
    slipped = False
    shut: set[str] = set()
    out: set[int] = set()
    at_shut: dict[str, int] = {}  # a grab or place while a container is shut: its id -> its index
    n = -1
    for e in events:
        if isinstance(e, Perturbed) and not e.event.ended:
            if e.event.object and e.event.kind in ("slip", "move_object"):
                moved.add(normalise(e.event.object))
            slipped |= e.event.kind == "slip"
            if e.event.kind == "close_container" and e.event.container:
                shut.add(normalise(e.event.container))
        elif isinstance(e, ToolResult) and e.name == "look_around" and e.structured and not e.is_error:
            moved.clear()
            slipped = False
        elif isinstance(e, ToolResult) and e.id in at_shut:
            index = at_shut.pop(e.id)
            said = e.structured or {}
            if said.get("container") or _CLOSED in str(said.get("message", "")):  # (no `container` before 4.3)
                out.add(index)
        elif isinstance(e, ToolCall):
            n += 1
            args = e.arguments or {}
            thing = args.get("object")
            if (e.name == "grab" and isinstance(thing, str) and normalise(thing) in moved) or (
                e.name == "place" and slipped
            ):
                out.add(n)
            elif e.name in ("grab", "place") and shut:
                at_shut[e.id] = n  # the world's doing if its result says the container is closed
            elif e.name == "open" and isinstance(args.get("furniture"), str):
                shut.discard(normalise(str(args["furniture"])))
    return out


def bounding_optimum(row: AttemptRow, events: Sequence[TraceEvent]) -> int | None:
    """The optimum additional steps are counted against, when it bounds the attempt: `optimal_steps` is
    the plan in the world fully seen and calm, so an attempt that had to explore (under partial
    observation) or to recover (a perturbation happened) has none."""
    partial = "partial_observation" in row.capabilities or row.observe in ("room", "location")
    perturbed = any(isinstance(e, Perturbed) for e in events)
    return None if partial or perturbed else row.optimal_steps


def _is_parse_error(c: _Call, offered: set[str] | None) -> bool:
    if c.call.arguments is None:
        return True
    if offered is not None and c.call.name not in offered:
        return True
    if c.result is None or not c.result.is_error or c.result.structured is not None:
        return False
    return c.result.content.startswith((_INVALID_ARGUMENTS, _NO_SUCH_TOOL))


def _grabbed_later(calls: list[_Call], after: int, name: str) -> bool:
    target = normalise(name)
    return any(
        c.call.name == "grab" and c.executed and not c.failed and normalise(str(c.data.get("object") or "")) == target
        for c in calls[after + 1 :]
    )


def _action_categories(calls: list[_Call], i: int, names: SceneNames) -> set[str]:
    """The categories a failed robot action shows."""
    c = calls[i]
    code = c.data.get("error")
    message = str(c.data.get("message", ""))
    found: set[str] = set()
    # The server resolves names before anything else, except place's empty-hand check: only then (or
    # with no error code at all) are the names judged here.
    unresolved = code in _UNCHECKED_NAMES and c.call.arguments is not None
    if code in _HALLUCINATION_CODES or (unresolved and names.unknown(c.call.name, c.call.arguments or {})):
        found.add("hallucination")
    if code in _AFFORDANCE_CODES:
        found.add("affordance")
    elif code == "not_at_location":
        found.add("wrong_order")
    elif code == "out_of_reach":  # before the move_to, or the open, it needs; or beyond the arm
        before = _MOVE_HINT in message or _OPEN_HINT in message or bool(c.data.get("container"))
        found.add("wrong_order" if before else "affordance")
    elif code == "position_occupied":
        occupant = _OCCUPIED_BY.search(message)
        later = occupant is not None and _grabbed_later(calls, i, occupant.group(1))
        found.add("wrong_order" if later else "affordance")
    return found


def _goal_met(events: Sequence[TraceEvent]) -> bool | None:
    """The ground truth's verdict in the trace (None when the trace has none)."""
    for e in reversed(events):
        if isinstance(e, Verdict):
            return e.success
        if isinstance(e, RunFinished) and e.true_success is not None:
            return e.true_success
    return None


def robot_actions(events: Sequence[TraceEvent], *, successful: bool = False) -> int:
    """The robot actions the server ran (move_to, grab, place; with `successful`, only those that succeeded)."""
    return sum(
        1 for c in _calls(events) if c.call.name in ROBOT_ACTIONS and c.executed and not (successful and c.failed)
    )


def classify(
    events: Sequence[TraceEvent],
    *,
    feasible: bool = True,
    optimal_steps: int | None = None,
    scene: SceneNames | None = None,
) -> dict[str, int]:
    """The taxonomy's counts for one attempt's trace; every category measurable is a key (zero
    included): `additional_step` only with `optimal_steps`."""
    counts = {c: 0 for c in CATEGORIES if c != "additional_step" or optimal_steps is not None}
    started = next((e for e in events if isinstance(e, RunStarted)), None)
    offered = set(started.tools) if started is not None else None
    names = SceneNames(
        locations=set(scene.locations) if scene else set(),
        objects=set(scene.objects) if scene else set(),
        positions={k: set(v) for k, v in scene.positions.items()} if scene else {},
    )
    for e in events:
        if isinstance(e, ToolResult) and e.name == "look_around" and e.structured and not e.is_error:
            names.add_look_around(e.structured)
    calls = _calls(events)
    by_the_world = moved_unseen(events)
    ended = False
    counts["parse"] += sum(e.text_tool_calls for e in events if isinstance(e, ModelTurn))
    for i, c in enumerate(calls):
        if _is_parse_error(c, offered):
            counts["parse"] += 1
            continue
        if c.call.slip is not None:  # read as meant and run: a parse slip, and judged as run
            counts["parse"] += 1
        if c.call.name == "end_task" and c.result is not None and not c.result.is_error:
            ended = True
        if c.call.name in ROBOT_ACTIONS and c.failed and i not in by_the_world:
            for category in _action_categories(calls, i, names):
                counts[category] += 1
    if feasible and ended and _goal_met(events) is False:
        counts["missing_step"] += 1
    if optimal_steps is not None:
        counts["additional_step"] = max(0, robot_actions(events, successful=True) - optimal_steps)
    return counts


def slips(events: Sequence[TraceEvent]) -> dict[str, int]:
    """The slips of an attempt that are not zero: `double_encoded` arguments (run as meant),
    `text_tool_calls` (written as text, not run), turns `cut_at_token_limit` (`finish_reason: length`)."""
    turns = [e for e in events if isinstance(e, ModelTurn)]
    counts = {
        "double_encoded": sum(1 for e in events if isinstance(e, ToolCall) and e.slip == "double_encoded"),
        "text_tool_calls": sum(e.text_tool_calls for e in turns),
        "cut_at_token_limit": sum(1 for e in turns if e.finish_reason == "length"),
    }
    return {k: v for k, v in counts.items() if v}


def row_fields(
    events: Sequence[TraceEvent], *, feasible: bool = True, optimal_steps: int | None = None
) -> dict[str, Any]:
    """What an `AttemptRow` takes from its trace: `errors` (the taxonomy), its `slips`, `robot_actions`,
    the `perturbations` that happened and how the agent met the first (`robocog.agent.analysis.recovery`)."""
    return {
        "errors": classify(events, feasible=feasible, optimal_steps=optimal_steps),
        "slips": slips(events),
        "robot_actions": robot_actions(events),
        "perturbations": [e.event.kind for e in events if isinstance(e, Perturbed) and not e.event.ended],
        **recovery.row_fields(events, feasible=feasible),
    }


def annotate(row: AttemptRow, events: Sequence[TraceEvent]) -> AttemptRow:
    """The row with its trace's taxonomy and robot actions (judged by the row's feasibility, and by its
    optimum where that bounds the attempt: `bounding_optimum`)."""
    optimum = bounding_optimum(row, events)
    update = row_fields(events, feasible=row.feasible, optimal_steps=optimum)
    return row.model_copy(update=update)


def classify_file(
    path: Path, *, feasible: bool = True, optimal_steps: int | None = None, scene: SceneNames | None = None
) -> dict[str, int]:
    """The taxonomy of a trace file."""
    return classify(read_trace(path), feasible=feasible, optimal_steps=optimal_steps, scene=scene)


def total(counts: Iterable[dict[str, int]]) -> dict[str, int]:
    """Counts summed per category (a category absent from every attempt stays absent)."""
    out: dict[str, int] = {}
    for one in counts:
        for k, v in one.items():
            out[k] = out.get(k, 0) + v
    return {k: out[k] for k in CATEGORIES if k in out}
