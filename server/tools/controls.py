"""The eval profile's controls for harnesses: reset the world, begin and check a task, clear the memory.

A model driving the robot never sees these (clients leave them out, and the default profile does
not publish them); they are not counted as the episode's tool calls.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import BaseModel, Field

from robocog.server.tools.base import CONTROL, DESTRUCTIVE, Tool, at_most
from robocog.server.world.tasks import evaluate
from robocog.shared.limits import EPISODE_ID_CHARS, NAME_CHARS
from robocog.shared.perturbations import MAX_PERTURBATIONS, Perturbation
from robocog.shared.results import TaskVerdict, WorldState
from robocog.shared.suite import DEFAULT_SUITE

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

logger = logging.getLogger("robocog.server.session")


TaskIdArg = Annotated[
    str,
    Field(description="A task id from robocog://tasks, e.g. 'T1'", min_length=1, max_length=NAME_CHARS),
    at_most(NAME_CHARS, "give a task id from robocog://tasks, e.g. 'T1'"),
]
InstanceArg = Annotated[
    str | None,
    Field(
        description="An instance of the suite to set the world up for, e.g. 'dev-swap-003' "
        "(assets/suites/SUITE/*.jsonl; `robocog suite list --split dev`)",
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give an instance id from the suite's splits, e.g. 'dev-swap-003'"),
]
SuiteArg = Annotated[
    str,
    Field(
        description=f"The suite the instance belongs to (default {DEFAULT_SUITE})", min_length=1, max_length=NAME_CHARS
    ),
    at_most(NAME_CHARS, f"give a suite's name, e.g. '{DEFAULT_SUITE}'"),
]
EpisodeIdArg = Annotated[
    str | None,
    Field(
        description="The harness's id of this attempt; a retry of the attempt (even on a new server) "
        "gives the same id, and its end_task report replaces the earlier one instead of adding a second. "
        "Default: a new random id.",
        min_length=1,
        max_length=EPISODE_ID_CHARS,
    ),
    at_most(EPISODE_ID_CHARS, "use a short id, e.g. a hash of what identifies the attempt"),
]


class BeginTaskResult(BaseModel):
    """The episode begin_task started."""

    task_id: str = Field(description="the task the episode is for")
    prompt: str = Field(description="the task's instruction, as the T1/T2 prompts give it")
    episode: int = Field(description="the number of the episode that began")
    episode_id: str = Field(description="the episode's id (the one given, or a new random one)")
    scratchpad_entries: int = Field(description="entries on the scratchpad (kept from before, or 0)")


class ClearMemoryResult(BaseModel):
    """The outcome of clear_memory."""

    removed: int = Field(description="records removed from this memory namespace")
    freed_bytes: int | None = Field(
        default=None, description="with drop: bytes of the namespace's files removed from disk (0 on a Chroma server)"
    )


def reset_world(
    robot: RobotSession,
    seed: Annotated[int | None, Field(description="Seed of the world's random generator")] = None,
    randomize: Annotated[bool, Field(description="Start objects on seeded random free positions")] = False,
    memory_labels: Annotated[
        Literal["believed", "verified"] | None,
        Field(description="What search_memory reports as an episode's status from now on"),
    ] = None,
    search_k: Annotated[
        int | None,
        Field(description="How many experiences search_memory returns from now on when k is not given", ge=1, le=20),
    ] = None,
    memory_namespace: Annotated[
        str | None,
        Field(
            description="The memory namespace this robot reads and writes from now on (letters, digits, '.', "
            "'_', '-'), so trials sharing a server or a Chroma server never mix; default: the server's "
            "--memory-namespace",
            min_length=1,
            max_length=NAME_CHARS,
        ),
        at_most(NAME_CHARS, "use a short namespace, e.g. 'study-trial-3'"),
    ] = None,
    instance: InstanceArg = None,
    suite: SuiteArg = DEFAULT_SUITE,
    observe: Annotated[
        Literal["location", "room", "house"] | None,
        Field(
            description="What look_around reveals from now on: the robot's 'location', its 'room', or the "
            "whole 'house' (the server's --observe until set)"
        ),
    ] = None,
    perturbations: Annotated[
        list[Perturbation] | None,
        Field(
            description="What goes wrong in this episode (a slipping grasp, an object moved, a container closed, "
            "a corridor blocked), each due at a tool call and announced or silent; default: the scene's own "
            "(none in the shipped scenes)",
            max_length=MAX_PERTURBATIONS,
        ),
    ] = None,
    clear_memory: Annotated[
        bool,
        Field(
            description="Forget every record of the memory namespace first (memory_namespace's, when given), "
            "as clear_memory does: a harness's unit begins so, in one call"
        ),
    ] = False,
) -> WorldState:
    """Put the world back to its start state and begin a new episode. Episodic memory is kept, unless
    clear_memory. memory_labels, search_k, memory_namespace and observe, when given, hold from now on
    (until set again). With an instance of a suite: the world of the instance's scene, set to the
    instance's start (seed and randomize do not apply), and the instance's task (and its earlier
    tasks, ID-pre1, ...) can be begun and checked by id. perturbations hold for this episode only."""
    if instance is not None and (seed is not None or randomize):
        raise ValueError("give an instance, or a seed and randomize: an instance has its own seed and start")
    if memory_namespace is not None:
        robot.use_namespace(memory_namespace)
    if clear_memory:
        _forget(robot)
    if instance is not None:
        state = robot.begin_instance(suite, instance, perturbations)
    else:
        state = robot.reset(seed=seed, options={"randomize": randomize}, perturbations=perturbations)
    if memory_labels is not None:
        robot.memory_labels = memory_labels
    if search_k is not None:
        robot.search_k = search_k
    if observe is not None:
        robot.observe = observe
    return state


def begin_task(
    robot: RobotSession,
    task_id: TaskIdArg,
    keep_scratchpad: Annotated[
        bool, Field(description="Keep the scratchpad's entries (the paper carries them from T1 into T2)")
    ] = False,
    episode_id: EpisodeIdArg = None,
) -> BeginTaskResult:
    """Begin a new episode for a task, before its first tool call: the world as it is now is the
    baseline check_task judges against, no tool calls yet, no report. The scratchpad is cleared
    unless keep_scratchpad. Call it before every task, so that a task in which the model makes no
    call is judged, and recorded, as its own episode. An episode stores at most one memory record:
    give the same episode_id when retrying an attempt, and the retry's report replaces the first."""
    episode = robot.begin_task(task_id, keep_scratchpad=keep_scratchpad, episode_id=episode_id)
    return BeginTaskResult(
        task_id=task_id,
        prompt=robot.task(task_id).prompt,
        episode=episode.number,
        episode_id=episode.id,
        scratchpad_entries=len(robot.scratchpad),
    )


def check_task(
    robot: RobotSession,
    task_id: TaskIdArg,
    record: Annotated[
        bool,
        Field(
            description="Write the verdict into the episode's memory record (false: judge only; a harness about "
            "to drop the memory namespace has no use for it there)"
        ),
    ] = True,
) -> TaskVerdict:
    """The ground-truth verdict of a task for the world as it is now (once nothing moves), against
    the current episode's start, with a reason per object. If the current episode ended with a report (and
    was not begun for another task), the verdict is written into that episode's memory record,
    and into no other (unless record is false)."""
    episode = robot.episode
    world = robot.world
    closed = {name: world.furniture(name).state == "closed" for name in world.container_names}
    verdict = evaluate(robot.task(task_id), world.placements_at_rest(), episode.baseline, episode.report, closed)
    same_task = episode.task_id is None or episode.task_id == task_id
    if record and episode.ended and episode.record_id is not None and same_task:
        try:
            robot.memory.set_verified(episode.record_id, "success" if verdict.success else "failure")
        except KeyError:  # the record was deleted since (clear_memory, here or by a robot sharing the memory)
            logger.info("check_task: the episode's memory record is gone; the verdict is written nowhere")
    return verdict


def clear_memory(
    robot: RobotSession,
    drop: Annotated[
        bool,
        Field(
            description="Also delete the namespace itself, with its files on disk, and go back to the server's "
            "own namespace: for a namespace reset_world(memory_namespace=...) made for one unit, once the unit "
            "ends (the server's own namespace cannot be dropped)"
        ),
    ] = False,
) -> ClearMemoryResult:
    """Forget every stored episode in this robot's memory namespace; with drop, delete the namespace."""
    if drop:
        removed = robot.memory.count()
        return ClearMemoryResult(removed=removed, freed_bytes=robot.drop_namespace())
    return ClearMemoryResult(removed=_forget(robot))


def _forget(robot: RobotSession) -> int:
    """Delete every record of the robot's memory namespace; how many there were."""
    removed = robot.memory.count()
    if removed:  # a unit's new namespace is empty: no need to list its records (Chroma holds the GIL)
        robot.memory.clear()
    return removed


RESET_WORLD = Tool("reset_world", "Reset the world", DESTRUCTIVE, reset_world, kind="control", changes_world=True)
BEGIN_TASK = Tool("begin_task", "Begin a task", CONTROL, begin_task, kind="control")
CHECK_TASK = Tool("check_task", "Check a task", CONTROL, check_task, kind="control")
CLEAR_MEMORY = Tool("clear_memory", "Clear episodic memory", DESTRUCTIVE, clear_memory, kind="control")
