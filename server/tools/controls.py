"""The eval profile's controls for harnesses: reset the world, check a task, clear the memory.

A model driving the robot never sees these (clients leave them out, and the default profile does
not publish them); they are not counted as the episode's tool calls.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import BaseModel, Field

from robocog.server.tools.base import CONTROL, DESTRUCTIVE, Tool
from robocog.server.world.tasks import evaluate
from robocog.shared.results import TaskVerdict, WorldState

if TYPE_CHECKING:
    from robocog.server.session import RobotSession


class ClearMemoryResult(BaseModel):
    """The outcome of clear_memory."""

    removed: int = Field(description="records removed from this memory namespace")


def reset_world(
    robot: RobotSession,
    seed: Annotated[int | None, Field(description="Seed of the world's random generator")] = None,
    randomize: Annotated[bool, Field(description="Start objects on seeded random free positions")] = False,
    memory_labels: Annotated[
        Literal["believed", "verified"] | None,
        Field(description="What search_memory reports as an episode's status from now on"),
    ] = None,
) -> WorldState:
    """Put the world back to its start state and begin a new episode. Episodic memory is kept."""
    state = robot.reset(seed=seed, options={"randomize": randomize})
    if memory_labels is not None:
        robot.memory_labels = memory_labels
    return state


def check_task(
    robot: RobotSession,
    task_id: Annotated[str, Field(description="A task id from robocog://tasks, e.g. 'T1'")],
) -> TaskVerdict:
    """The ground-truth verdict of a task for the world as it is now, with a reason per object.
    If the episode ended with a report, the verdict is written into that memory record."""
    episode = robot.episode
    verdict = evaluate(robot.task(task_id), robot.world.placements(), episode.baseline)
    if episode.ended and episode.record_id is not None:
        robot.memory.set_verified(episode.record_id, "success" if verdict.success else "failure")
    return verdict


def clear_memory(robot: RobotSession) -> ClearMemoryResult:
    """Forget every stored episode in this server's memory namespace."""
    removed = robot.memory.count()
    robot.memory.clear()
    return ClearMemoryResult(removed=removed)


RESET_WORLD = Tool("reset_world", "Reset the world", DESTRUCTIVE, reset_world, kind="control")
CHECK_TASK = Tool("check_task", "Check a task", CONTROL, check_task, kind="control")
CLEAR_MEMORY = Tool("clear_memory", "Clear episodic memory", DESTRUCTIVE, clear_memory, kind="control")
