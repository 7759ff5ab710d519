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


Condition = Annotated[AtLocation | AtPosition | Swapped, Field(discriminator="kind")]


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
