"""The household world: a PyBullet simulation with the robot's actions and physics ground truth.

Each `World` owns its own PyBullet client (no global connection), so several worlds live in one
process without interfering. Actions return result models (never raise for a failure a model
could have avoided). Where an object is comes from its pose and contacts, not from bookkeeping.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet
import pybullet_data
from pybullet_utils.bullet_client import BulletClient

from robocog.assets import ASSETS_DIR
from robocog.server.world.cstdio import stdout_to_stderr
from robocog.server.world.navigation import SemanticMap, closest, resolve
from robocog.server.world.robot import Robot
from robocog.shared.errors import WorldError
from robocog.shared.results import (
    GrabResult,
    LocationView,
    LookAroundResult,
    MoveResult,
    ObjectPlacement,
    PlaceResult,
    PositionState,
    PositionView,
    RobotState,
    WorldState,
)
from robocog.shared.scene import PlacePosition, Scene, SceneObject, load_robot, load_scene

DEFAULT_SCENE = ASSETS_DIR / "scenes" / "household.yaml"

#: Called with (done, total, message) while a long action runs.
ProgressFn = Callable[[float, float, str], None]
#: Polled between path segments; True stops a motion at the location just reached.
StopFn = Callable[[], bool]


@dataclass(frozen=True)
class _Position:
    """A place position with its support body and surface height resolved."""

    spec: PlacePosition
    support_body: int
    surface_z: float

    @property
    def key(self) -> tuple[str, str]:
        return self.spec.location, self.spec.name

    def contains_xy(self, x: float, y: float) -> bool:
        (cx, cy), (sx, sy) = self.spec.center, self.spec.size
        return abs(x - cx) <= sx / 2 and abs(y - cy) <= sy / 2


@dataclass
class _Object:
    spec: SceneObject
    body: int
    bottom: float  # distance from the body origin down to its lowest point, upright
    top: float  # distance from the body origin up to its highest point, upright


class World:
    """A seeded, headless-by-default household with one mobile manipulator."""

    def __init__(
        self,
        scene: Scene | Path | str | None = None,
        *,
        seed: int | None = None,
        randomize: bool = False,
        gui: bool = False,
    ) -> None:
        if scene is None or isinstance(scene, str | Path):
            scene = load_scene(Path(scene) if scene is not None else DEFAULT_SCENE)
        self.scene = scene
        self.robot_spec = load_robot(ASSETS_DIR / scene.robot)
        self.map = SemanticMap(scene)
        self.client = self._connect(gui)
        # Bound once: BulletClient's attribute lookup costs more than a step's bookkeeping.
        self._step_simulation = functools.partial(pybullet.stepSimulation, physicsClientId=self.client._client)
        self.np_random = np.random.default_rng(seed)
        self.seed = seed
        self.steps = 0
        self._grasp: tuple[str, int] | None = None  # (object name, constraint id)
        self.reset(seed=seed, randomize=randomize)

    # --- construction --------------------------------------------------------------------------

    @staticmethod
    def _connect(gui: bool) -> BulletClient:
        if gui and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            raise WorldError(
                "the PyBullet GUI needs a display, and none is set (DISPLAY is empty); "
                "run headless (the default) or start an X server such as Xvfb"
            )
        with stdout_to_stderr():
            client = BulletClient(connection_mode=pybullet.GUI if gui else pybullet.DIRECT)
        client.setAdditionalSearchPath(pybullet_data.getDataPath())
        return client

    def _build(self) -> None:
        c, scene, phys = self.client, self.scene, self.scene.physics
        c.setGravity(0, 0, phys.gravity)
        c.setTimeStep(phys.time_step)
        c.setPhysicsEngineParameter(numSolverIterations=phys.solver_iterations, deterministicOverlappingPairs=1)
        # Maximal coordinates make every body a plain rigid body: about half the cost per step
        # of the default multibody representation, and resting bodies can sleep.
        self.floor = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_PLANE), -1, useMaximalCoordinates=True)
        c.changeVisualShape(self.floor, -1, rgbaColor=[0.9, 0.9, 0.88, 1])
        self.static_bodies: list[int] = [self.floor]
        for wall in scene.walls:
            (x0, y0), (x1, y1) = wall.start, wall.end
            length = math.hypot(x1 - x0, y1 - y0)
            half = [length / 2 + wall.thickness / 2, wall.thickness / 2, wall.height / 2]
            col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
            vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=[0.75, 0.75, 0.72, 1])
            yaw = math.atan2(y1 - y0, x1 - x0)
            self.static_bodies.append(
                c.createMultiBody(
                    0,
                    col,
                    vis,
                    [(x0 + x1) / 2, (y0 + y1) / 2, wall.height / 2],
                    c.getQuaternionFromEuler([0, 0, yaw]),
                    useMaximalCoordinates=True,
                )
            )
        self.parts: dict[str, int] = {"floor": self.floor}
        part_top: dict[str, float] = {"floor": 0.0}
        for item in scene.furniture:
            for part in item.parts:
                half = [s / 2 for s in part.size]
                col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
                vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=part.color)
                body = c.createMultiBody(0, col, vis, list(part.center), useMaximalCoordinates=True)
                key = f"{item.name}/{part.name}"
                self.parts[key] = body
                part_top[key] = part.center[2] + part.size[2] / 2
                self.static_bodies.append(body)
        for body in self.static_bodies:
            c.changeDynamics(body, -1, lateralFriction=0.9)
        self.positions: dict[tuple[str, str], _Position] = {}
        for pos in scene.place_positions:
            self.positions[(pos.location, pos.name)] = _Position(pos, self.parts[pos.support], part_top[pos.support])
        self.objects: dict[str, _Object] = {}
        for obj in scene.objects:
            self.objects[obj.name] = self._make_object(obj)
        start = scene.location(scene.robot_start)
        self.robot = Robot(c, self.robot_spec, start.x, start.y)
        for obj in self.objects.values():
            # Starting poses; reset() finalises them.
            self._pose_object_at_start(obj)
        self._settle()

    def _make_object(self, obj: SceneObject) -> _Object:
        c = self.client
        if obj.shape == "urdf":
            assert obj.urdf is not None
            body = c.loadURDF(obj.urdf, [0, 0, 5], globalScaling=obj.urdf_scale, useMaximalCoordinates=True)
            c.changeDynamics(body, -1, mass=obj.mass)
            c.changeVisualShape(body, -1, rgbaColor=obj.color)
        else:
            if obj.shape == "box":
                half = [s / 2 for s in obj.size]
                col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
                vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=obj.color)
            else:
                col = c.createCollisionShape(pybullet.GEOM_CYLINDER, radius=obj.size[0] / 2, height=obj.size[2])
                vis = c.createVisualShape(
                    pybullet.GEOM_CYLINDER, radius=obj.size[0] / 2, length=obj.size[2], rgbaColor=obj.color
                )
            body = c.createMultiBody(obj.mass, col, vis, [0, 0, 5], useMaximalCoordinates=True)
        c.changeDynamics(
            body,
            -1,
            lateralFriction=0.9,
            rollingFriction=0.001,
            spinningFriction=0.001,
            # Resting bodies sleep (and cost nothing per step) until something touches them.
            activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING,
        )
        c.resetBasePositionAndOrientation(body, [0, 0, 5], [0, 0, 0, 1])
        lo, hi = c.getAABB(body)
        return _Object(obj, body, bottom=5 - lo[2], top=hi[2] - 5)

    def _pose_object_at_start(self, obj: _Object) -> None:
        start = obj.spec.start
        if start.pose is not None:
            x, y, z = start.pose
            self._put(obj, x, y, z, start.yaw)
        else:
            assert start.location is not None and start.position is not None
            self._put_on(obj, self.positions[(start.location, start.position)], start.yaw)

    def _put(self, obj: _Object, x: float, y: float, z: float, yaw: float) -> None:
        self.client.resetBasePositionAndOrientation(
            obj.body, [x, y, z], self.client.getQuaternionFromEuler([0, 0, yaw])
        )
        self.client.resetBaseVelocity(obj.body, [0, 0, 0], [0, 0, 0])
        self._wake(obj.body)

    def _wake(self, body: int) -> None:
        self.client.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_WAKE_UP)

    def _put_on(self, obj: _Object, pos: _Position, yaw: float, xy: tuple[float, float] | None = None) -> None:
        x, y = xy if xy is not None else pos.spec.center
        self._put(obj, x, y, pos.surface_z + obj.bottom + 0.001, yaw)

    # --- episode control -----------------------------------------------------------------------

    def reset(self, seed: int | None = None, randomize: bool = False) -> WorldState:
        """Back to the scene's start: the paper's static setup, or seeded random free positions.

        With `randomize`, every graspable object starts on a distinct place position drawn (with
        a random yaw) from the world's one generator, reseeded by `seed` when given.

        The simulation is rebuilt from nothing (about 0.1 s), so a reset world is exactly a new
        world: no sleeping state or contact cache of the past episode carries over.
        """
        if seed is not None:
            self.seed = seed
            self.np_random = np.random.default_rng(seed)
        self._grasp = None
        self.client.resetSimulation()
        self._build()
        if randomize:
            graspable = [o for o in self.objects.values() if o.spec.graspable]
            keys = list(self.positions)
            if len(keys) < len(graspable):
                raise WorldError(f"cannot randomize: {len(graspable)} objects but {len(keys)} place positions")
            chosen = self.np_random.choice(len(keys), size=len(graspable), replace=False)
            for obj, index in zip(graspable, chosen, strict=True):
                self._put_on(obj, self.positions[keys[int(index)]], float(self.np_random.uniform(-math.pi, math.pi)))
            self._settle()
        self.steps = 0
        return self.state()

    def close(self) -> None:
        """Disconnect this world's PyBullet client."""
        with contextlib.suppress(pybullet.error):
            self.client.disconnect()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- simulation primitives -----------------------------------------------------------------

    def _step(self) -> None:
        self._step_simulation()
        self.steps += 1

    def _speed(self, body: int) -> float:
        lin, _ = self.client.getBaseVelocity(body)
        return math.sqrt(lin[0] ** 2 + lin[1] ** 2 + lin[2] ** 2)

    def _settle(self, bodies: Iterable[int] | None = None) -> None:
        """Step until the given (default: all loose) objects rest, or the settle budget runs out."""
        held = self._grasp[0] if self._grasp else None
        watch = list(bodies) if bodies is not None else [o.body for n, o in self.objects.items() if n != held]
        phys = self.scene.physics
        for i in range(phys.settle_steps):
            self._step()
            if i >= 3 and all(self._speed(b) < phys.rest_speed for b in watch):
                break

    def _follow(self, trajectory: Iterable[tuple[list[float], list[float]]]) -> None:
        for q, dq in trajectory:
            self.robot.set_joints(q, dq)
            self._step()

    def _move_arm(self, q: list[float]) -> None:
        self._follow(self.robot.joint_trajectory(q, self.scene.physics.time_step))

    def _move_hand_straight(self, start: tuple[float, float, float], end: tuple[float, float, float]) -> None:
        """Move the hand along a straight line (IK at a few waypoints, joint interpolation between)."""
        n = max(1, math.ceil(math.dist(start, end) / 0.1))
        for i in range(1, n + 1):
            waypoint = tuple(a + (b - a) * i / n for a, b in zip(start, end, strict=True))
            q, _ = self.robot.solve_ik(waypoint)  # type: ignore[arg-type]
            self._move_arm(q)

    def _approach_point(self, target: tuple[float, float, float]) -> tuple[float, float, float]:
        """A point in line between the base and `target`, just outside the base, slightly higher."""
        dx, dy = target[0] - self.robot.x, target[1] - self.robot.y
        dist = math.hypot(dx, dy)
        keep = min(dist, max(self.robot_spec.base_size[:2]) * 0.5 + 0.1)
        return (self.robot.x + dx / dist * keep, self.robot.y + dy / dist * keep, target[2] + 0.03)

    # --- ground truth --------------------------------------------------------------------------

    def _touches(self, body: int, support: int) -> bool:
        return bool(self.client.getClosestPoints(body, support, 0.005))

    def _position_of(self, obj: _Object) -> _Position | None:
        """The place position whose region holds the object's footprint at its surface height."""
        (x, y, _z), _ = self.client.getBasePositionAndOrientation(obj.body)
        bottom = self.client.getAABB(obj.body)[0][2]
        for pos in self.positions.values():
            if pos.contains_xy(x, y) and pos.surface_z - 0.02 <= bottom <= pos.surface_z + 0.08:
                return pos
        return None

    def placement(self, name: str) -> ObjectPlacement:
        """Where the object `name` is, from the physics state."""
        obj = self.objects[name]
        (x, y, z), _ = self.client.getBasePositionAndOrientation(obj.body)
        room = next((r.name for r in self.scene.rooms if r.x[0] <= x <= r.x[1] and r.y[0] <= y <= r.y[1]), None)
        if self._grasp is not None and self._grasp[0] == name:
            return ObjectPlacement(
                object=name,
                state="held",
                location=self.robot_location(),
                xyz=(x, y, z),
                resting=False,
                room=room,
            )
        resting = self._speed(obj.body) < self.scene.physics.rest_speed
        pos = self._position_of(obj)
        if pos is not None and resting and self._touches(obj.body, pos.support_body):
            return ObjectPlacement(
                object=name,
                state="on_position",
                location=pos.spec.location,
                position=pos.spec.name,
                xyz=(x, y, z),
                resting=True,
                room=room,
            )
        near, dist = self.map.nearest(x, y)
        supported = resting and any(self._touches(obj.body, b) for b in self.static_bodies)
        return ObjectPlacement(
            object=name,
            state="loose",
            location=near if dist <= self.scene.location_radius else None,
            xyz=(x, y, z),
            resting=supported,
            room=room,
        )

    def placements(self) -> dict[str, ObjectPlacement]:
        """Every object's placement."""
        return {name: self.placement(name) for name in self.objects}

    def occupant(self, pos: _Position, ignore: str | None = None) -> str | None:
        """The object (other than `ignore`) lying in a position's region, moving or not."""
        for name, obj in self.objects.items():
            if name == ignore or (self._grasp and self._grasp[0] == name):
                continue
            if self._position_of(obj) is pos:
                return name
        return None

    def robot_location(self) -> str:
        """The location the robot stands at (the nearest one; it only ever stops at locations)."""
        name, _ = self.map.nearest(self.robot.x, self.robot.y)
        return name

    @property
    def holding(self) -> str | None:
        return self._grasp[0] if self._grasp else None

    def state(self) -> WorldState:
        """The whole ground truth."""
        placements = self.placements()
        by_position = {(p.location, p.position): p.object for p in placements.values() if p.state == "on_position"}
        z = self.robot_spec.base_size[2] / 2
        return WorldState(
            robot=RobotState(
                location=self.robot_location(),
                xyz=(self.robot.x, self.robot.y, z),
                yaw=self.robot.yaw,
                holding=self.holding,
            ),
            objects=list(placements.values()),
            positions=[
                PositionState(location=loc, position=name, occupied_by=by_position.get((loc, name)))
                for loc, name in self.positions
            ],
            sim_time_s=self.steps * self.scene.physics.time_step,
            steps=self.steps,
        )

    # --- actions -------------------------------------------------------------------------------

    def look_around(self) -> LookAroundResult:
        """The robot's location, its hand, and every location's objects, positions and neighbours."""
        placements = self.placements()
        here = self.robot_location()
        views = []
        for name in self.map.names:
            objects = [p.object for p in placements.values() if p.state != "held" and p.location == name]
            positions = [
                PositionView(name=pname, occupied_by=self.occupant(pos))
                for (loc, pname), pos in self.positions.items()
                if loc == name
            ]
            views.append(
                LocationView(
                    name=name,
                    neighbours=list(self.map.neighbours[name]),
                    objects=objects,
                    place_positions=positions,
                )
            )
        hand = f"holding the {self.holding}" if self.holding else "holding nothing"
        visible = next(v for v in views if v.name == here)
        seen = ", ".join(visible.objects) or "no objects"
        return LookAroundResult(
            status="success",
            message=f"The robot is at {here}, {hand}. Here: {seen}.",
            location=here,
            holding=self.holding,
            locations=views,
        )

    def move_to(
        self, location: str, progress: ProgressFn | None = None, should_stop: StopFn | None = None
    ) -> MoveResult:
        """Drive along the shortest path over the semantic map (A*) to `location`."""
        here = self.robot_location()
        goal = resolve(location, self.map.names)
        if goal is None:
            message, suggestions = _unknown("location", location, self.map.names)
            return MoveResult(
                status="failure", error="unknown_location", message=message, suggestions=suggestions, location=here
            )
        path = self.map.shortest_path(here, goal)
        if path is None:
            return MoveResult(
                status="failure",
                error="no_path",
                message=f"There is no path from {here} to {goal} on the map.",
                location=here,
            )
        if len(path) == 1:
            return MoveResult(status="success", message=f"The robot is already at {goal}.", location=goal, path=path)
        step_len = self.robot_spec.base_speed * self.scene.physics.time_step
        driven = 0.0
        for i, (a, b) in enumerate(itertools.pairwise(path)):
            if should_stop is not None and should_stop():
                return MoveResult(
                    status="failure",
                    error="interrupted",
                    message=f"Stopped at {a} before reaching {goal}: the motion was interrupted.",
                    location=a,
                    path=path[: i + 1],
                    distance_m=round(driven, 3),
                )
            (ax, ay), (bx, by) = self.map.points[a], self.map.points[b]
            n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / step_len))
            for k in range(1, n + 1):
                self.robot.set_base(ax + (bx - ax) * k / n, ay + (by - ay) * k / n, self.robot.yaw)
                self._step()
            driven += math.hypot(bx - ax, by - ay)
            if progress is not None:
                progress(i + 1, len(path) - 1, f"reached {b}")
        return MoveResult(
            status="success",
            message=f"Moved to {goal} via {' -> '.join(path)} ({driven:.1f} m).",
            location=goal,
            path=path,
            distance_m=round(driven, 3),
        )

    def grab(self, object: str) -> GrabResult:
        """Reach for `object` and attach it to the hand if the hand gets close enough."""
        name = resolve(object, list(self.objects))
        if name is None:
            message, suggestions = _unknown("object", object, list(self.objects))
            return GrabResult(
                status="failure",
                error="unknown_object",
                message=message + " Use look_around to see where they are.",
                suggestions=suggestions,
                object=object,
                holding=self.holding,
            )
        if self.holding is not None:
            verb = "already holding it" if self.holding == name else f"already holding the {self.holding}"
            return GrabResult(
                status="failure",
                error="already_holding",
                message=f"The robot is {verb}; it holds one object at a time. Place the {self.holding} first.",
                object=name,
                holding=self.holding,
            )
        obj = self.objects[name]
        if not obj.spec.graspable:
            return GrabResult(
                status="failure",
                error="not_graspable",
                message=f"The {name} cannot be grasped: it is too large or heavy for the robot.",
                object=name,
            )
        here = self.robot_location()
        where = self.placement(name)
        if where.location != here:
            hint = (
                f"it is at {where.location}; move_to('{where.location}') first"
                if where.location
                else ("it is not near any location the robot can reach")
            )
            return GrabResult(
                status="failure",
                error="out_of_reach",
                message=f"The {name} is out of reach from {here}: {hint}.",
                object=name,
            )
        (x, y, _), _ = self.client.getBasePositionAndOrientation(obj.body)
        grasp_point = (x, y, self.client.getAABB(obj.body)[1][2] + self.robot_spec.grasp_clearance)
        _, err = self.robot.solve_ik(grasp_point)
        if err > self.robot_spec.grasp_threshold:
            return GrabResult(
                status="failure",
                error="out_of_reach",
                message=f"The arm cannot reach the {name} from where the robot stands ({err:.2f} m short).",
                object=name,
            )
        approach = self._approach_point(grasp_point)
        lifted = (grasp_point[0], grasp_point[1], grasp_point[2] + 0.03)
        self._move_arm(self.robot.solve_ik(approach)[0])
        self._move_hand_straight(approach, lifted)
        self._move_hand_straight(lifted, grasp_point)
        hand = self.robot.end_effector()
        (x, y, _), _ = self.client.getBasePositionAndOrientation(obj.body)
        top = (x, y, self.client.getAABB(obj.body)[1][2])
        gap = math.dist(hand, top)
        if gap > self.robot_spec.grasp_threshold + self.robot_spec.grasp_clearance:
            self._move_arm(list(self.robot_spec.arm.rest_pose))
            return GrabResult(
                status="failure",
                error="out_of_reach",
                message=f"The hand stopped {gap:.2f} m from the {name}; it could not be grasped from here.",
                object=name,
            )
        self._attach(name)
        self._move_hand_straight(grasp_point, lifted)
        self._move_hand_straight(lifted, approach)
        self._move_arm(list(self.robot_spec.arm.carry_pose))
        origin = f"{where.location} / {where.position}" if where.position else str(where.location)
        return GrabResult(status="success", message=f"Grabbed the {name} from {origin}.", object=name, holding=name)

    def place(self, location: str, position: str) -> PlaceResult:
        """Put the held object down on `position` at `location`, where the robot must be."""
        held = self.holding
        if held is None:
            return PlaceResult(
                status="failure",
                error="nothing_held",
                message="The robot is not holding anything. Grab an object first.",
                location=location,
                position=position,
            )
        here = self.robot_location()
        loc = resolve(location, self.map.names)
        if loc is None:
            message, suggestions = _unknown("location", location, self.map.names)
            return PlaceResult(
                status="failure",
                error="unknown_location",
                message=message,
                suggestions=suggestions,
                object=held,
                location=location,
                position=position,
                holding=held,
            )
        names = [p for (lname, p) in self.positions if lname == loc]
        if loc != here:
            return PlaceResult(
                status="failure",
                error="not_at_location",
                message=f"The robot is at {here}, not at {loc}. move_to('{loc}') first.",
                object=held,
                location=loc,
                position=position,
                holding=held,
            )
        pname = resolve(position, names)
        if pname is None:
            suggestions = closest(position, names) or names
            listing = ", ".join(names) if names else "none (nothing can be placed here)"
            return PlaceResult(
                status="failure",
                error="unknown_position",
                message=f"{loc} has no place position {position!r}. Its positions: {listing}.",
                suggestions=suggestions,
                object=held,
                location=loc,
                position=position,
                holding=held,
            )
        pos = self.positions[(loc, pname)]
        occupant = self.occupant(pos, ignore=held)
        if occupant is not None:
            free = [p for p in names if self.occupant(self.positions[(loc, p)], ignore=held) is None]
            alternatives = f" Free positions here: {', '.join(free)}." if free else f" No position at {loc} is free."
            return PlaceResult(
                status="failure",
                error="position_occupied",
                message=f"The {pname} position of {loc} is occupied by the {occupant}.{alternatives}",
                suggestions=free,
                object=held,
                location=loc,
                position=pname,
                holding=held,
            )
        obj = self.objects[held]
        (ox, oy, oz), _ = self.client.getBasePositionAndOrientation(obj.body)
        hand = self.robot.end_effector()
        drop_z = pos.surface_z + obj.bottom + self.robot_spec.place_clearance
        cx, cy = pos.spec.center
        target_hand = (cx + hand[0] - ox, cy + hand[1] - oy, drop_z + hand[2] - oz)
        _, err = self.robot.solve_ik(target_hand)
        if err > self.robot_spec.grasp_threshold:
            return PlaceResult(
                status="failure",
                error="out_of_reach",
                message=f"The arm cannot reach the {pname} position of {loc} ({err:.2f} m short).",
                object=held,
                location=loc,
                position=pname,
                holding=held,
            )
        approach = self._approach_point(target_hand)
        self._move_arm(self.robot.solve_ik(approach)[0])
        self._move_hand_straight(approach, target_hand)
        yaw = self.client.getEulerFromQuaternion(self.client.getBasePositionAndOrientation(obj.body)[1])[2]
        self._release()
        # The hand has no fingers: the object is let go upright just above the surface.
        self._put_on(obj, pos, yaw, xy=(cx, cy))
        self._move_hand_straight(target_hand, approach)
        self._move_arm(list(self.robot_spec.arm.rest_pose))
        self._settle([obj.body])
        where = self.placement(held)
        if where.state == "on_position" and (where.location, where.position) == (loc, pname):
            return PlaceResult(
                status="success",
                message=f"Placed the {held} on the {pname} position of {loc}.",
                object=held,
                location=loc,
                position=pname,
            )
        ended = f"{where.location} / {where.position}" if where.position else f"near {where.location}"
        return PlaceResult(
            status="failure",
            error="place_failed",
            message=f"The {held} was released but did not come to rest on {loc} / {pname}; it is {ended}.",
            object=held,
            location=loc,
            position=pname,
        )

    # --- grasping ------------------------------------------------------------------------------

    def _attach(self, name: str) -> None:
        c, body = self.client, self.objects[name].body
        self._wake(body)
        hand_pos, hand_orn = self.robot.end_effector_pose()
        obj_pos, obj_orn = c.getBasePositionAndOrientation(body)
        inv_pos, inv_orn = c.invertTransform(hand_pos, hand_orn)
        rel_pos, rel_orn = c.multiplyTransforms(inv_pos, inv_orn, obj_pos, obj_orn)
        constraint = c.createConstraint(
            self.robot.arm,
            self.robot.ee,
            body,
            -1,
            pybullet.JOINT_FIXED,
            [0, 0, 0],
            parentFramePosition=rel_pos,
            childFramePosition=[0, 0, 0],
            parentFrameOrientation=rel_orn,
        )
        c.changeConstraint(constraint, maxForce=500)
        self._grasp = (name, constraint)

    def _release(self) -> None:
        if self._grasp is None:
            return
        _, constraint = self._grasp
        self._grasp = None
        with contextlib.suppress(pybullet.error):
            self.client.removeConstraint(constraint)


def _unknown(kind: str, name: str, known: list[str]) -> tuple[str, list[str]]:
    """The failure message for a name that matches nothing, and the closest known names."""
    suggestions = closest(name, known)
    guess = f" Did you mean {_quote_list(suggestions)}?" if suggestions else ""
    return f"There is no {kind} called {name!r}.{guess} Known {kind}s: {', '.join(known)}.", suggestions


def _quote_list(names: list[str]) -> str:
    quoted = [f"'{n}'" for n in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
