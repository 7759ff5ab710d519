"""Task specifications: a prompt and its success condition, read from `assets/tasks/*.yaml`.

A task's success condition is a list of declarative conditions over where objects rest; the
server evaluates them against the physics state (see `robocog.server.world.tasks`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from robocog.shared.scene import load_yaml_model


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class AtLocation(_Strict):
    """Each object rests on some place position of `location` (one object per position)."""

    kind: Literal["at_location"] = "at_location"
    objects: list[str] = Field(min_length=1)
    location: str


class AtPosition(_Strict):
    """`object` rests on `position` of `location`."""

    kind: Literal["at_position"] = "at_position"
    object: str
    location: str
    position: str


class Swapped(_Strict):
    """The two objects rest on each other's place positions of when the task started."""

    kind: Literal["swapped"] = "swapped"
    objects: tuple[str, str]


class OnFurniture(_Strict):
    """Each object rests on one of `positions`, the place positions a piece of furniture supports
    (one object per position); `furniture` names it in the verdict."""

    kind: Literal["on_furniture"] = "on_furniture"
    objects: list[str] = Field(min_length=1)
    furniture: str
    positions: list[tuple[str, str]] = Field(min_length=1, description="(location, position) pairs")


class AtPositions(_Strict):
    """Each (object, location, position) of `targets` holds: a whole arrangement."""

    kind: Literal["at_positions"] = "at_positions"
    targets: list[tuple[str, str, str]] = Field(min_length=1, description="(object, location, position) triples")


class Unchanged(_Strict):
    """The objects rest where they rested when the task started (default: every object that rested
    on a place position then)."""

    kind: Literal["unchanged"] = "unchanged"
    objects: list[str] = []


class HonestFailure(_Strict):
    """The episode ended with end_task reporting failure: the honest answer to a task that cannot be done."""

    kind: Literal["honest_failure"] = "honest_failure"


class WorldSane(_Strict):
    """The robot's hand is empty and every object that rested on a place position when the task
    started rests on one now (nothing dropped, nothing left in the hand)."""

    kind: Literal["world_sane"] = "world_sane"


Condition = Annotated[
    AtLocation | AtPosition | Swapped | OnFurniture | AtPositions | Unchanged | HonestFailure | WorldSane,
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
