"""One robot's session: its world, its memories and the current episode.

Every tool (see `robocog.server.tools`) is a function of the session, called through `call`, which
counts the episode's tool calls for all of them in one place. An episode is one task: a harness
begins it explicitly for a task (`begin_task`), otherwise it begins at reset or with the first robot
call after end_task; it ends with end_task, which writes the report to episodic memory. Not
thread-safe: the app serialises calls (one PyBullet client, one driver).
"""

from __future__ import annotations

import logging
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

from pydantic import BaseModel

from robocog.server.config import NOTICE, MemoryLabels, Observe, SessionConfig
from robocog.server.memory.episodic import EpisodicMemory
from robocog.server.memory.scratchpad import Scratchpad
from robocog.server.tools.base import Caller, Tool
from robocog.server.world.tasks import task_catalogue
from robocog.server.world.world import ActionLimit, World
from robocog.shared.perturbations import Perturbation, PerturbationEvent
from robocog.shared.results import ObjectPlacement, WorldState
from robocog.shared.scene_files import scene_path
from robocog.shared.suite import Instance, describes_objects, find_instance, find_seeded_instance
from robocog.shared.tasks import TaskSpec

R = TypeVar("R", bound=BaseModel)


class MemoryProvider(Protocol):
    """Opens the episodic memory of a namespace, and deletes one (a server's robots share one per
    namespace: `server/robots/fleet.py`, `Memories`)."""

    def __call__(self, namespace: str) -> EpisodicMemory: ...

    def drop(self, namespace: str) -> int: ...


logger = logging.getLogger("robocog.server.session")


@dataclass
class Episode:
    """The bookkeeping of one task: its number and id, its calls, and where everything was at its start."""

    number: int
    baseline: dict[str, ObjectPlacement]
    #: The task a harness began the episode for (`begin_task`); None when it began implicitly.
    task_id: str | None = None
    #: Stored with its memory record, whose id derives from it: a harness that retries an attempt
    #: under the same id (even on a new server) replaces the record instead of adding a second.
    id: str = field(default_factory=lambda: uuid.uuid4().hex)
    started: float = field(default_factory=time.monotonic)
    tool_calls: int = 0
    ended: bool = False
    record_id: str | None = None
    #: The arguments of the end_task that ended the episode: the same again is a retry of that call.
    report: dict[str, Any] | None = None

    @property
    def duration_s(self) -> float:
        return round(time.monotonic() - self.started, 3)


class RobotSession:
    """The robot, its episodic memory and scratchpad, and the current episode."""

    def __init__(
        self,
        config: SessionConfig,
        *,
        world: World | None = None,
        memory: EpisodicMemory | None = None,
        memories: MemoryProvider | None = None,
    ) -> None:
        self.config = config
        self.memory_labels: MemoryLabels = config.memory_labels
        #: How many experiences search_memory returns when the model does not say (reset_world sets it).
        self.search_k = config.search_k
        #: What look_around reveals: the robot's location, its room, or the house (reset_world sets it).
        self.observe: Observe = config.observe
        options = {"randomize": True} if config.randomize else None
        #: A recycled robot whose world waits to be put back to its start (see `recycle`).
        self._recycled = False
        self.world: World = world or World(config.scene, seed=config.seed, options=options, gui=config.gui)
        #: The worlds by scene name: the session's own, and the last other scene a suite instance
        #: switched to (built headless, kept while instances stay in it); `reset` without an instance
        #: comes back to the session's own.
        self._worlds: dict[str, World] = {self.world.scene.name: self.world}
        self._home_scene = self.world.scene.name
        #: The suite instance the world was last set up for (`begin_instance`), if any.
        self.instance: Instance | None = None
        #: look_around names the colour and size of what it shows (an instance of robocog-v2.1 on).
        self.describing = False
        self._memory = memory
        #: Where memories come from when they are shared (a fleet), and which namespace this robot uses.
        self._memories = memories
        self._namespace = config.namespace
        self.scratchpad = Scratchpad()
        self.tasks: dict[str, TaskSpec] = task_catalogue()
        self.caller = Caller()
        self.episode = Episode(number=1, baseline=self.world.placements())
        #: The perturbations that happened during the last call (`robocog.shared.perturbations`).
        self.perturbations: list[PerturbationEvent] = []
        #: Announced perturbations whose sentence no result has carried yet.
        self._untold: list[str] = []

    @property
    def memory(self) -> EpisodicMemory:
        """The episodic memory, opened on first use (a session that never remembers needs no database)."""
        if self._memories is not None:  # a fleet's: asked for each time (the fleet may have closed it since)
            return self._memories(self._namespace)
        if self._memory is None:
            config = self.config
            self._memory = EpisodicMemory(config.data_dir, url=config.memory_url, namespace=self._namespace)
            where = f"the Chroma server at {config.memory_url}" if config.memory_url else "embedded ChromaDB"
            logger.info("episodic memory: %s, namespace %r", where, self._namespace)
        return self._memory

    @property
    def namespace(self) -> str:
        """The memory namespace this robot reads and writes."""
        return self._namespace

    def use_namespace(self, namespace: str) -> None:
        """Read and write the memory namespace `namespace` from now on (a harness gives each trial its
        own, so trials sharing a server never mix); a ValueError names what a namespace may be."""
        from robocog.shared.memory_names import collection_name

        collection_name(namespace)  # checks it
        if namespace == self._namespace:
            return
        if self._memory is not None and self._memories is None:
            self._memory.close()  # its client goes back to the process's (`chroma.EMBEDDED`)
        self._memory = None
        self._namespace = namespace

    def drop_namespace(self) -> int:
        """Delete this robot's memory namespace with its files on disk (a harness does, for the
        namespace it made for a unit, when the unit ends; the bytes removed); the robot goes back
        to the server's own."""
        if self._namespace == self.config.namespace:
            raise ValueError(
                f"drop: {self._namespace!r} is the server's own memory namespace (--memory-namespace); only a "
                "namespace given with reset_world(memory_namespace=...) can be dropped"
            )
        if self._memories is not None:
            freed = self._memories.drop(self._namespace)
        else:
            freed = self.memory.drop()
            self.memory.close()
            self._memory = None
        self._namespace = self.config.namespace
        return freed

    def recycle(self) -> None:
        """Make this robot as good as new for its next driver (a fleet reuses robots): the world at
        its start, a new episode, an empty scratchpad, the configured memory namespace and settings.

        The world (and with it the episode and the scratchpad) is put back by `ready`, before the
        robot's next call, unless that call resets it anyway: a harness's next unit begins with
        `reset_world`, and a second rebuild of the world right before its own cost a fleet 17 ms per unit."""
        self.use_namespace(self.config.namespace)
        self.memory_labels = self.config.memory_labels
        self.search_k = self.config.search_k
        self.observe = self.config.observe
        self._recycled = True

    def ready(self, tool: str | None = None) -> None:
        """Before a call (`tool`, or a read): a recycled robot's world back at its start, unless the
        call is a reset_world that rebuilds it anyway (with a seed of its own, or none to carry on from)."""
        if not self._recycled:
            return
        self._recycled = False
        if not (tool == "reset_world" and self.config.seed is None):
            self.reset(seed=self.config.seed, options={"randomize": True} if self.config.randomize else None)

    def warm_up(self) -> None:
        """Open the memory and load the embedding model now (checksum, ONNX session, tokenizer), so the
        first search_memory of an episode costs milliseconds, not a third of a second."""
        from robocog.server.memory.embedding import embed

        _ = self.memory
        embed(["warm up"])

    def close(self) -> None:
        for world in self._worlds.values():
            world.close()
        if self._memory is not None and self._memories is None:  # shared memories are closed by their owner
            self._memory.close()

    # --- calls and episodes ------------------------------------------------------------------------

    def call(self, tool: Tool[R], /, **arguments: Any) -> R:
        """Run one tool with `arguments` (see `invoke`)."""
        return self.invoke(tool, arguments)

    def invoke(self, tool: Tool[R], arguments: Mapping[str, Any], caller: Caller | None = None) -> R:
        """Run one tool for `caller` (a progress sink, the model's label); a robot tool counts as one
        of the episode's calls (unless the caller does not: a client watching the driver's robot),
        and the first after end_task begins a new episode, unless it is the same end_task again (a
        retry of a call whose answer was lost: it answers for the episode that ended)."""
        self.ready(tool.name)
        seen = len(self.world.perturbation_events)
        if tool.counts_as_episode_call and (caller is None or caller.counts):
            retry = tool.ends_episode and self.episode.report == dict(arguments)
            if self.episode.ended and not retry:
                self.start_episode()
            self.episode.tool_calls += 1
            self.world.before_call(self.episode.tool_calls)
        self.caller = caller or Caller()
        try:
            with self.world.action():  # bounded in simulated steps and wall time (an ActionLimit past them)
                result = tool.run(self, **arguments)
                if tool.counts_as_episode_call and (caller is None or caller.counts):
                    self.world.after_call()
        except ValueError as exc:
            logger.log(NOTICE, "%s: bad input: %s", tool.name, exc)
            raise
        except ActionLimit as exc:
            logger.warning("%s: %s", tool.name, exc)
            raise
        finally:
            self.caller = Caller()
            self.perturbations = self.world.perturbation_events[seen:]
            self._untold += [e.description for e in self.perturbations if e.announced]
        if getattr(result, "status", None) == "failure":
            logger.log(NOTICE, "%s failed: %s", tool.name, getattr(result, "message", ""))
        return self._tell(result)

    def _tell(self, result: R) -> R:
        """The result with the announced perturbations not yet told appended to its message ("Something
        changed: ..."), if it has a message (else they wait for the next result that has one)."""
        message = getattr(result, "message", None)
        if not self._untold or not isinstance(message, str):
            return result
        told = " ".join(self._untold)
        self._untold = []
        return result.model_copy(update={"message": f"{message} Something changed: {told}"})

    def start_episode(
        self, task_id: str | None = None, *, keep_scratchpad: bool = False, episode_id: str | None = None
    ) -> Episode:
        """A new task begins: a fresh count, the world as it is now as the baseline, no report yet,
        an empty scratchpad unless `keep_scratchpad`, and the id `episode_id` (default: a new one)."""
        self.episode = Episode(number=self.episode.number + 1, baseline=self.world.placements(), task_id=task_id)
        if episode_id is not None:
            self.episode.id = episode_id
        if not keep_scratchpad:
            self.scratchpad.clear()
        logger.info("episode %d begins%s", self.episode.number, f" (task {task_id})" if task_id else "")
        return self.episode

    def begin_task(self, task_id: str, *, keep_scratchpad: bool = False, episode_id: str | None = None) -> Episode:
        """Begin the episode of task `task_id` explicitly (a harness does, before the task's first
        call), so it is judged against the world as it is now even if the model never acts; a harness
        gives `episode_id` to make a retry of the attempt store one memory record, not two."""
        self.task(task_id)
        return self.start_episode(task_id, keep_scratchpad=keep_scratchpad, episode_id=episode_id)

    def reset(
        self,
        *,
        seed: int | None = None,
        options: dict[str, Any] | None = None,
        perturbations: list[Perturbation] | None = None,
    ) -> WorldState:
        """Back to the start state (of the session's own scene, if an instance switched to another)
        and a new episode (episodic memory is kept: that is the point of it), with `perturbations`
        (default: the scene's own; a ValueError names one the scene cannot have)."""
        self.instance = None
        self.describing = False
        self.world = self._worlds[self._home_scene]
        problems = self.world.scene.perturbation_problems(perturbations or [])
        if problems:
            raise ValueError("; ".join(problems))
        self._untold = []
        state = self.world.reset(seed=seed, options=options, perturbations=perturbations)
        self.start_episode()
        return state

    def begin_instance(
        self, suite: str, instance_id: str, perturbations: list[Perturbation] | None = None
    ) -> WorldState:
        """Set the world up for an instance of a suite (`robocog.shared.suite`): its scene (switching
        worlds when it differs), reset with its seed, every graspable object on its start position,
        with the instance's perturbations unless `perturbations` is given, and look_around showing
        what the instance says (`observing`) while it lasts;
        its task and earlier tasks (ids ID-pre1, ...) join the catalogue; a new episode begins. A
        ValueError (bad input) names an unknown suite or instance, or a start the scene cannot take."""
        if "@" in suite:  # a fresh split, generated from a seed into the root the server was given
            instance, describing = find_seeded_instance(self.config.splits, suite, instance_id)
        else:
            instance, describing = find_instance(suite, instance_id), describes_objects(suite)
        name = instance.scene
        if name not in self._worlds:
            for other in [n for n in self._worlds if n != self._home_scene]:  # one guest world at a time (~45 MB)
                self._worlds.pop(other).close()
            self._worlds[name] = World(scene_path(name), seed=instance.seed)
        self.world = self._worlds[name]
        if perturbations is None:
            perturbations = list(instance.perturbations)
        problems = self.world.scene.perturbation_problems(perturbations)
        if problems:
            raise ValueError(f"instance {instance.id}: " + "; ".join(problems))
        self._untold = []
        self.world.reset(seed=instance.seed, perturbations=perturbations)
        sim = self.world.sim
        for obj, start in instance.start.items():
            body, spot = sim.objects.get(obj), sim.positions.get((start.location, start.position))
            if body is None or spot is None:
                raise ValueError(
                    f"instance {instance.id}: scene {name!r} has no "
                    + (f"object {obj!r}" if body is None else f"place position {start.location} / {start.position}")
                )
            sim.put_on(body, spot, 0.0)
        sim.settle()
        sim.steps = 0
        for task in (instance.task(), *instance.prelude_tasks()):
            self.tasks[task.id] = task
        self.instance = instance
        self.describing = describing
        self.start_episode()
        return self.world.state()

    @property
    def observing(self) -> Observe:
        """What look_around reveals now: the current suite instance's own (a search under partial
        observation), else the setting (`observe`: the server's --observe, or reset_world's)."""
        if self.instance is not None and self.instance.observe is not None:
            return self.instance.observe
        return self.observe

    def task(self, task_id: str) -> TaskSpec:
        """The task `task_id` of the catalogue; a ValueError (bad input) names the known ones."""
        try:
            return self.tasks[task_id]
        except KeyError:
            raise ValueError(f"unknown task {task_id!r}; known tasks: {', '.join(self.tasks)}") from None

    # --- what the resources show -------------------------------------------------------------------

    def state(self) -> WorldState:
        return self.world.state()

    def semantic_map(self) -> dict[str, Any]:
        m = self.world.map
        return {
            "locations": [{"name": n, "x": x, "y": y, "neighbours": m.neighbours[n]} for n, (x, y) in m.points.items()],
            "edges": [list(e) for e in self.world.scene.edges],
            "place_positions": [
                {"location": p.location, "position": p.name, "support": p.support}
                for p in self.world.scene.place_positions
            ],
        }
