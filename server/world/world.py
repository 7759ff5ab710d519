"""The household world: a PyBullet simulation, its ground truth and the robot's physical actions.

`World` composes the parts (builder, episode, truth, actions over one `Sim`) behind a small API.
Each world owns its own PyBullet client (no global connection), so several worlds live in one
process without interfering, and one random generator, reseeded Gymnasium-style by `reset(seed=)`.
What a tool may do and how its failures are worded is the tools' business (robocog.server.tools).
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import numpy as np
import pybullet

from robocog.assets import ASSETS_DIR
from robocog.server.world import actions, articulation, containers, episode, truth
from robocog.server.world.actions import ProgressFn, Reach
from robocog.server.world.articulation import Operation
from robocog.server.world.builder import connect
from robocog.server.world.navigation import SemanticMap
from robocog.server.world.perturb import Perturber, Trip
from robocog.server.world.sim import ActionLimit, Budget, Sim
from robocog.shared.appearance import attributes
from robocog.shared.errors import WorldError
from robocog.shared.perturbations import Perturbation, PerturbationEvent
from robocog.shared.results import FurnitureState, ObjectPlacement, Observe, WorldState
from robocog.shared.robot_spec import load_robot
from robocog.shared.scene import Scene, SceneObject
from robocog.shared.scene_bounds import ACTION_STEPS, ACTION_WALL_S
from robocog.shared.scene_files import load_scene, scene_path

DEFAULT_SCENE = ASSETS_DIR / "scenes" / "household.yaml"

__all__ = ["DEFAULT_SCENE", "ActionLimit", "Operation", "ProgressFn", "Reach", "Trip", "World"]


class World:
    """A seeded, headless-by-default household with one mobile manipulator."""

    def __init__(
        self,
        scene: Scene | Path | str | None = None,
        *,
        seed: int | None = None,
        options: dict[str, Any] | None = None,
        gui: bool = False,
    ) -> None:
        if scene is None or isinstance(scene, str | Path):
            scene = load_scene(scene_path(scene) if scene is not None else DEFAULT_SCENE)  # a name or a path
        self.scene = scene
        self.robot_spec = load_robot(scene.robot_file())
        episode.check_options(options)
        self.client = connect(gui)
        #: What the running action may still spend (steps, wall time): `action()` bounds one.
        self.budget = Budget()
        self.seed = seed
        self.np_random = np.random.default_rng(seed)
        self.sim: Sim
        self.perturber: Perturber
        self.reset(seed=seed, options=options)

    # --- episodes ------------------------------------------------------------------------------

    def reset(
        self,
        *,
        seed: int | None = None,
        options: dict[str, Any] | None = None,
        perturbations: list[Perturbation] | None = None,
    ) -> WorldState:
        """Back to the scene's start: the paper's static setup, or with `options={"randomize": True}`
        every graspable object on a distinct random place position with a random yaw, drawn from the
        world's one generator (reseeded by `seed` when given, else continued).

        The simulation is rebuilt from nothing (about 0.1 s), so a reset world is exactly a new
        world: no sleeping state or contact cache of the past episode carries over.

        `perturbations` (default: the scene's own, none in the shipped scenes) are what goes wrong in
        this episode (`robocog.server.world.perturb`), seeded by the world's seed; a WorldError names one
        that refers to something the scene lacks.
        """
        episode.check_options(options)
        chosen = list(self.scene.perturbations if perturbations is None else perturbations)
        problems = self.scene.perturbation_problems(chosen)
        if problems:
            raise WorldError("; ".join(problems))
        if seed is not None:
            self.seed = seed
            self.np_random = np.random.default_rng(seed)
        self.sim = episode.reset(self.client, self.scene, self.robot_spec, self.np_random, options)
        self.sim.budget = self.budget
        self.perturber = Perturber.arm(chosen, self.seed)
        return self.state()

    def action(
        self, steps: int = ACTION_STEPS, wall_s: float = ACTION_WALL_S
    ) -> contextlib.AbstractContextManager[None]:
        """Bound what runs inside (one robot action, a tool call) to `steps` simulated steps and `wall_s`
        seconds: past either, or when the server shuts down, it stops with `ActionLimit` (a WorldError)."""
        return self.budget.action(steps, wall_s)

    def close(self) -> None:
        """Disconnect this world's PyBullet client."""
        with contextlib.suppress(pybullet.error):
            self.client.disconnect()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def map(self) -> SemanticMap:
        return self.sim.map

    @property
    def steps(self) -> int:
        """Physics steps since the episode started."""
        return self.sim.steps

    # --- the scene -----------------------------------------------------------------------------

    @property
    def object_names(self) -> list[str]:
        """Every object's name, in scene order."""
        return list(self.sim.objects)

    def object_spec(self, name: str) -> SceneObject:
        return self.sim.objects[name].spec

    def position_names(self, location: str) -> list[str]:
        """The place positions of `location`, in scene order."""
        return [name for loc, name in self.sim.positions if loc == location]

    def furniture_locations(self) -> dict[str, str]:
        """Each piece of furniture (scene order, then the containers) and the location it stands at: the
        location of the place positions it supports, else the location nearest the middle of its parts;
        a container's is its own."""
        supported = {p.support.split("/")[0]: p.location for p in self.scene.place_positions}
        out: dict[str, str] = {}
        for f in self.scene.furniture:
            if f.name in supported:
                out[f.name] = supported[f.name]
            else:
                x = sum(b.center[0] for b in f.parts) / len(f.parts)
                y = sum(b.center[1] for b in f.parts) / len(f.parts)
                out[f.name] = self.map.nearest(x, y)[0]
        out.update((box.name, box.location) for box in self.scene.containers)
        return out

    @property
    def container_names(self) -> list[str]:
        """Every piece of furniture that opens (drawers, cabinets, fridges), in scene order."""
        return list(self.sim.containers)

    # --- ground truth --------------------------------------------------------------------------

    def placement(self, name: str) -> ObjectPlacement:
        """Where the object `name` is, from the physics state."""
        return truth.placement(self.sim, name)

    def placements(self) -> dict[str, ObjectPlacement]:
        """Every object's placement, in scene order."""
        return truth.placements(self.sim)

    def placements_at_rest(self) -> dict[str, ObjectPlacement]:
        """Every object's placement once the world has come to rest (at most the scene's settle_steps).

        A cylinder standing on a board rocks on its rim now and then (Bullet's cylinder-box contact),
        and at an unlucky instant its speed tops rest_speed, so an object nobody touched read as loose.
        A verdict is about where things end up, so it waits for a step at which nothing moves."""
        self.sim.settle()
        return truth.placements(self.sim)

    def occupant(self, location: str, position: str, ignore: str | None = None) -> str | None:
        """The object (other than `ignore` and the held one) lying on a place position, moving or not."""
        return truth.occupant(self.sim, self.sim.positions[(location, position)], ignore)

    def robot_location(self) -> str:
        """The location the robot stands at."""
        return truth.robot_location(self.sim)

    @property
    def holding(self) -> str | None:
        """The object in the robot's hand, if any."""
        return truth.holding(self.sim)

    def state(self) -> WorldState:
        """The whole ground truth."""
        return truth.state(self.sim)

    def furniture(self, name: str) -> FurnitureState:
        """A container's state (open or closed, from its joint) and what its interior holds."""
        return truth.furniture(self.sim, name)

    def blocking(self, name: str) -> list[str]:
        """The objects touching the drawer or door of the container `name` (what may be in its way)."""
        return containers.touching(self.sim, name)

    def appearance(self, name: str) -> tuple[str, str]:
        """What a person sees of the object `name`: its colour and its size, in words."""
        spec = self.sim.objects[name].spec
        return attributes(spec.color, spec.size)

    def hidden(self, where: ObjectPlacement) -> bool:
        """Whether an object is shut in a closed container (then it can be neither seen nor reached)."""
        return truth.hidden(self.sim, where) is not None

    def visible_positions(self, location: str) -> list[str]:
        """The place positions of `location` not shut inside a closed container, in scene order."""
        return [p for p in self.position_names(location) if self.shut_position(location, p) is None]

    def observed_locations(self, observe: Observe) -> list[str]:
        """The locations whose contents the robot perceives (map order): all of them ('house'), those in
        the robot's room ('room'; its own location only when it stands in no room) or its own ('location')."""
        here = self.robot_location()
        if observe == "house":
            return list(self.map.names)
        if observe == "room":
            room = self.room_of(*self.map.points[here])
            if room is not None:
                return [n for n in self.map.names if self.room_of(*self.map.points[n]) == room]
        return [here]

    def room_of(self, x: float, y: float) -> str | None:
        """The room whose floor holds (x, y), if any (the first in scene order)."""
        return next((r.name for r in self.scene.rooms if r.x[0] <= x <= r.x[1] and r.y[0] <= y <= r.y[1]), None)

    def drawer_or_door_aabb(self, name: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The bounding box (world) of the container `name`'s drawer or door where physics has it now."""
        lo, hi = self.client.getAABB(self.sim.containers[name].body, 0)
        return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])

    def shut_in(self, name: str) -> str | None:
        """The closed container the object `name` is in (then it can be neither seen nor reached), if any."""
        return truth.hidden(self.sim, self.placement(name))

    def shut_position(self, location: str, position: str) -> str | None:
        """The closed container a place position is inside, if any."""
        return truth.shut_position(self.sim, self.sim.positions[(location, position)])

    # --- physical actions ----------------------------------------------------------------------

    def drive(self, path: list[str], progress: ProgressFn | None = None) -> float:
        """Drive along `path` (location names from where the robot is); the metres driven."""
        return actions.drive(self.sim, path, progress)

    def travel(self, path: list[str], progress: ProgressFn | None = None) -> Trip:
        """Drive along `path` as far as the corridors are clear (a blocked edge stops the robot before
        it), with whatever perturbation is due on the way (a held object may slip)."""
        return self.perturber.travel(self.sim, path, progress)

    def before_call(self, call: int) -> None:
        """The episode's robot tool call `call` begins: the perturbations due now happen."""
        self.perturber.before_call(self.sim, call)

    def after_call(self) -> None:
        """The robot tool call ends: what was due but waited for the robot to leave happens now."""
        self.perturber.after_call(self.sim)

    @property
    def perturbation_events(self) -> list[PerturbationEvent]:
        """The perturbations that happened since the last reset, in order."""
        return list(self.perturber.events)

    def pick(self, name: str) -> Reach:
        """Reach for the object `name` and hold it, if the hand gets close enough."""
        return actions.pick(self.sim, name)

    def put_down(self, location: str, position: str) -> Reach:
        """Put the held object down on `position` of `location`."""
        return actions.put_down(self.sim, location, position)

    def operate(self, name: str, *, opened: bool) -> Operation:
        """Open (or close) the container `name`: the hand to its handle, its joint driven by the motor."""
        op = articulation.operate(self.sim, name, opened)
        if opened and op.outcome != "unreachable":
            self.perturber.opened_by_robot(name)
        return op
