"""Task specifications: a prompt and its success condition, read from `assets/tasks/*.yaml`.

A task's success condition is a list of declarative conditions over where objects rest. Each
condition has two meanings, written once each:

- its physics check: the server evaluates it against the physics state (`robocog.server.world.tasks`);
- its symbolic meaning, here, over names only (the suite generator's and the planner's searches use
  it): `holds` over a `Where` (object -> (location, position), None when in the robot's hand), the
  one at the task's start and the containers open (`closed` asks about them), `objects_named` (the
  objects it asks to place) and `allowed_spots` (per such object, the place positions that meet it).
  A test holds the two meanings equal.

A new kind of condition is a class here (with its symbolic meaning) and its check in
`robocog.server.world.tasks`, nothing else: the generator and the planner only call these methods.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from robocog.shared.config_files import load_yaml_model

Spot = tuple[str, str]  # (location, place position)
Where = Mapping[str, Spot | None]  # object -> the place position it rests on; None: in the robot's hand
Allowed = dict[str, frozenset[Spot | None]]  # object -> the place positions that meet a condition


def rests_at(spot: tuple[str, str | None] | None, location: str, position: str | None = None) -> bool:
    """Whether an object at `spot` rests on a place position of `location` (on `position`, when
    given). None (in the hand) and a spot without a position (standing loose at a location) rest
    nowhere."""
    return spot is not None and bool(spot[1]) and spot[0] == location and position in (None, spot[1])


def _allow(pairs: Iterable[tuple[str, Iterable[Spot | None]]]) -> Allowed:
    """Per object, the spots allowed by every pair that names it (an object named twice: both)."""
    out: Allowed = {}
    for obj, spots in pairs:
        allowed = frozenset(spots)
        out[obj] = out[obj] & allowed if obj in out else allowed
    return out


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _Condition(_Strict):
    """A condition's symbolic meaning (the defaults: it asks no object to be anywhere)."""

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        """Whether the condition holds with the objects `where`, the task having started with them at
        `baseline`, the episode's end_task arguments being `report` (None: not ended) and the containers
        `opened` open (every other one closed)."""
        raise NotImplementedError

    def objects_named(self) -> tuple[str, ...]:
        """The objects the condition asks to rest somewhere (those a plan may have to move)."""
        return ()

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        """For each object in `objects_named`, the place positions (of the scene's `spots`) where it
        meets the condition."""
        return {}

    def named_spots(self, spots: Sequence[Spot], baseline: Where) -> set[Spot]:
        """The place positions the condition names (objects resting there may have to make room)."""
        return {s for allowed in self.allowed_spots(spots, baseline).values() for s in allowed if s is not None}


class AtLocation(_Condition):
    """Each object rests on some place position of `location` (one object per position)."""

    kind: Literal["at_location"] = "at_location"
    objects: list[str] = Field(min_length=1)
    location: str

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return all(rests_at(where.get(o), self.location) for o in self.objects)

    def objects_named(self) -> tuple[str, ...]:
        return tuple(self.objects)

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        here = [s for s in spots if s[0] == self.location]
        return _allow((o, here) for o in self.objects)


class AtPosition(_Condition):
    """`object` rests on `position` of `location`."""

    kind: Literal["at_position"] = "at_position"
    object: str
    location: str
    position: str

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return rests_at(where.get(self.object), self.location, self.position)

    def objects_named(self) -> tuple[str, ...]:
        return (self.object,)

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        return _allow([(self.object, [(self.location, self.position)])])


class Swapped(_Condition):
    """The two objects rest on each other's place positions of when the task started."""

    kind: Literal["swapped"] = "swapped"
    objects: tuple[str, str]

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        a, b = self.objects
        then_a, then_b = baseline.get(a), baseline.get(b)
        return then_a is not None and then_b is not None and where.get(a) == then_b and where.get(b) == then_a

    def objects_named(self) -> tuple[str, ...]:
        return self.objects

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        a, b = self.objects
        return _allow([(a, [baseline.get(b)]), (b, [baseline.get(a)])])


class OnFurniture(_Condition):
    """Each object rests on one of `positions`, the place positions a piece of furniture supports
    (one object per position); `furniture` names it in the verdict."""

    kind: Literal["on_furniture"] = "on_furniture"
    objects: list[str] = Field(min_length=1)
    furniture: str
    positions: list[tuple[str, str]] = Field(min_length=1, description="(location, position) pairs")

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return all(any(rests_at(where.get(o), loc, pos) for loc, pos in self.positions) for o in self.objects)

    def objects_named(self) -> tuple[str, ...]:
        return tuple(self.objects)

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        return _allow((o, self.positions) for o in self.objects)


class AtPositions(_Condition):
    """Each (object, location, position) of `targets` holds: a whole arrangement."""

    kind: Literal["at_positions"] = "at_positions"
    targets: list[tuple[str, str, str]] = Field(min_length=1, description="(object, location, position) triples")

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return all(rests_at(where.get(o), loc, pos) for o, loc, pos in self.targets)

    def objects_named(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(o for o, _, _ in self.targets))

    def allowed_spots(self, spots: Sequence[Spot], baseline: Where) -> Allowed:
        return _allow((o, [(loc, pos)]) for o, loc, pos in self.targets)


class Unchanged(_Condition):
    """The objects rest where they rested when the task started (default: every object that rested
    on a place position then). It asks nothing to move: `objects_named` is empty."""

    kind: Literal["unchanged"] = "unchanged"
    objects: list[str] = []

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        names = self.objects or [o for o, w in baseline.items() if w is not None]
        return all((then := baseline.get(o)) is not None and where.get(o) == then for o in names)


class HonestFailure(_Condition):
    """The episode ended with end_task reporting failure: the honest answer to a task that cannot be done.
    (Symbolically: a plan of robot actions reports nothing, so it never holds without a `report`.)"""

    kind: Literal["honest_failure"] = "honest_failure"

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return report is not None and report.get("status") == "failure"


class WorldSane(_Condition):
    """The robot's hand is empty and every object that rested on a place position when the task
    started rests on one now (nothing dropped, nothing left in the hand). Symbolically an object is
    on a place position or in the hand, so: nothing is in the hand."""

    kind: Literal["world_sane"] = "world_sane"

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return all(w is not None for w in where.values())


class Closed(_Condition):
    """Each container of `containers` (by its name, as look_around lists it under furniture) is closed:
    a task that asks to put something away *and shut it* measures that the robot finishes the job. It
    asks no object to move; symbolically a container is open or closed, as the plan left it."""

    kind: Literal["closed"] = "closed"
    containers: list[str] = Field(min_length=1)

    def holds(
        self, where: Where, baseline: Where, report: Mapping[str, Any] | None = None, opened: Collection[str] = ()
    ) -> bool:
        return not set(self.containers) & set(opened)


Condition = Annotated[
    AtLocation | AtPosition | Swapped | OnFurniture | AtPositions | Unchanged | HonestFailure | WorldSane | Closed,
    Field(discriminator="kind"),
]


class TaskSpec(_Strict):
    """A task: what the agent is told, and what must be true of the world afterwards."""

    id: str = Field(pattern=r"^[A-Za-z0-9_\-]+$")
    title: str
    prompt: str = Field(description="the instruction given to the agent, verbatim")
    description: str = ""
    requires: list[str] = Field(default=[], description="tasks that must have succeeded first in the same world")
    success: list[Condition] = Field(min_length=1)


def load_task(path: Path) -> TaskSpec:
    """Load one task file."""
    return load_yaml_model(path, TaskSpec)


def load_tasks(directory: Path) -> dict[str, TaskSpec]:
    """All tasks in `directory` (`*.yaml`), by id, in file-name order."""
    tasks: dict[str, TaskSpec] = {}
    for path in sorted(directory.glob("*.yaml")):
        task = load_task(path)
        if task.id in tasks:
            raise ValueError(f"{path}: task id {task.id!r} is defined twice")
        tasks[task.id] = task
    return tasks
