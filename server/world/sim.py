"""The simulation handle: one PyBullet client's bodies, robot and grasp, and the primitives every part needs.

A `Sim` is what the builder makes and what ground truth and the actions work on; it knows nothing
of either, so the world's parts depend one way: actions -> ground truth -> Sim, and
episode -> builder -> Sim.
"""

from __future__ import annotations

import contextlib
import functools
import math
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

import pybullet
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world.navigation import SemanticMap
from robocog.server.world.robot import Robot
from robocog.shared.containers import Geometry
from robocog.shared.errors import WorldError
from robocog.shared.robot_spec import RobotSpec
from robocog.shared.scene import PlacePosition, Scene, SceneObject
from robocog.shared.scene_bounds import ACTION_STEPS, ACTION_WALL_S

#: Set when the process is shutting down (its client has gone): every action stops at its next check.
SHUTTING_DOWN = threading.Event()
#: Steps between two looks at the clock and at `SHUTTING_DOWN` during an action.
_CHECK_EVERY = 64


class ActionLimit(WorldError):
    """A robot action could not finish within its bounds (simulated steps, wall time) or was stopped
    because the server is shutting down."""


class Budget:
    """What one robot action may still spend: simulated steps and wall time (`ACTION_STEPS`,
    `ACTION_WALL_S`). Outside an action (building a world) nothing is counted."""

    def __init__(self) -> None:
        self.used = 0
        self.steps = sys.maxsize
        self.check_at = sys.maxsize
        self.deadline = math.inf
        self.wall_s = math.inf

    @contextlib.contextmanager
    def action(self, steps: int = ACTION_STEPS, wall_s: float = ACTION_WALL_S) -> Iterator[None]:
        """Bound what runs inside to `steps` simulated steps and `wall_s` seconds (`ActionLimit` past either)."""
        outer = (self.used, self.steps, self.check_at, self.deadline, self.wall_s)
        self.used, self.steps, self.wall_s = 0, steps, wall_s
        self.deadline = time.monotonic() + wall_s
        self.check_at = min(_CHECK_EVERY, steps + 1)
        try:
            yield
        finally:
            self.used, self.steps, self.check_at, self.deadline, self.wall_s = outer

    def left(self) -> int:
        """Steps the running action may still take."""
        return max(0, self.steps - self.used)

    def afford(self, steps: int, what: str) -> None:
        """Refuse, before anything moves, a motion of `steps` steps that the action cannot pay for."""
        if steps > self.left():
            raise ActionLimit(
                f"{what} would take {steps:,} simulated steps, more than the {self.steps:,} one action may take; "
                "nothing moved"
            )

    def check(self) -> None:
        """Called every few steps: raise `ActionLimit` past a bound, or when the server is shutting down."""
        if self.used > self.steps:
            raise ActionLimit(f"the action took more than {self.steps:,} simulated steps and was stopped")
        if time.monotonic() > self.deadline:
            raise ActionLimit(f"the action took more than {self.wall_s:g} s and was stopped")
        if SHUTTING_DOWN.is_set():
            raise ActionLimit("the server is shutting down (its client has gone): the action was stopped")
        self.check_at = min(self.used + _CHECK_EVERY, self.steps + 1)


@dataclass(frozen=True)
class Position:
    """A place position with its support body and surface height resolved."""

    spec: PlacePosition
    support_body: int
    surface_z: float
    container: str | None = None  # the container whose interior floor supports it

    @property
    def key(self) -> tuple[str, str]:
        return self.spec.location, self.spec.name

    def contains_xy(self, x: float, y: float) -> bool:
        (cx, cy), (sx, sy) = self.spec.center, self.spec.size
        return abs(x - cx) <= sx / 2 and abs(y - cy) <= sy / 2


@dataclass
class Body:
    """A scene object's PyBullet body and its extent from the body origin."""

    spec: SceneObject
    body: int
    bottom: float  # distance from the body origin down to its lowest point, upright
    top: float  # distance from the body origin up to its highest point, upright


@dataclass(frozen=True)
class ContainerBody:
    """A container's multibody: its carcass is the base, its drawer or door link 0 on the one joint."""

    geometry: Geometry
    body: int

    @property
    def name(self) -> str:
        return self.geometry.spec.name


@dataclass(frozen=True)
class Grasp:
    """The object in the hand and the constraint that holds it there."""

    name: str
    constraint: int


@dataclass(eq=False)
class Sim:
    """One built scene in one PyBullet client: its bodies, the robot, what the hand holds, the step count."""

    client: BulletClient
    scene: Scene
    robot_spec: RobotSpec
    map: SemanticMap
    floor: int
    static_bodies: list[int]
    parts: dict[str, int]  # "furniture/part" (and "floor") -> body
    positions: dict[tuple[str, str], Position]  # (location, position) -> Position, in scene order
    objects: dict[str, Body]  # name -> Body, in scene order
    robot: Robot
    grasp: Grasp | None = None
    steps: int = 0
    containers: dict[str, ContainerBody] = field(default_factory=dict)  # name -> body, in scene order
    budget: Budget = field(default_factory=Budget)  # the running action's (the world's, across resets)
    _step_simulation: Callable[[], None] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # Bound once: BulletClient's attribute lookup costs more than a step's bookkeeping.
        self._step_simulation = functools.partial(pybullet.stepSimulation, physicsClientId=self.client._client)

    def step(self) -> None:
        self._step_simulation()
        self.steps += 1
        budget = self.budget
        budget.used += 1
        if budget.used >= budget.check_at:
            budget.check()

    def speed(self, body: int) -> float:
        lin, _ = self.client.getBaseVelocity(body)
        return math.sqrt(lin[0] ** 2 + lin[1] ** 2 + lin[2] ** 2)

    def settle(self, bodies: Iterable[int] | None = None) -> None:
        """Step until the given (default: all loose) objects rest, or the settle budget runs out."""
        held = self.grasp.name if self.grasp else None
        watch = list(bodies) if bodies is not None else [o.body for n, o in self.objects.items() if n != held]
        phys = self.scene.physics
        for i in range(phys.settle_steps):
            self.step()
            if i >= 3 and all(self.speed(b) < phys.rest_speed for b in watch):
                break

    def wake(self, body: int) -> None:
        self.client.changeDynamics(body, -1, activationState=pybullet.ACTIVATION_STATE_WAKE_UP)

    def put(self, obj: Body, x: float, y: float, z: float, yaw: float) -> None:
        """Teleport an object to (x, y, z) with `yaw`, at rest and awake."""
        self.client.resetBasePositionAndOrientation(
            obj.body, [x, y, z], self.client.getQuaternionFromEuler([0, 0, yaw])
        )
        self.client.resetBaseVelocity(obj.body, [0, 0, 0], [0, 0, 0])
        self.wake(obj.body)

    def joint(self, name: str) -> float:
        """The joint position of the container `name` (0 closed; metres or radians open)."""
        return float(self.client.getJointState(self.containers[name].body, 0)[0])

    def shift(self, pos: Position) -> tuple[float, float]:
        """How far a place position has moved from where the scene puts it: a drawer's slides out with it."""
        if pos.container is None:
            return 0.0, 0.0
        box = self.containers[pos.container]
        if not box.geometry.interior_moves:
            return 0.0, 0.0
        q = self.joint(pos.container)
        fx, fy = box.geometry.facing
        return fx * q, fy * q

    def center(self, pos: Position) -> tuple[float, float]:
        """A place position's centre now (a drawer's moves with the drawer)."""
        (cx, cy), (dx, dy) = pos.spec.center, self.shift(pos)
        return cx + dx, cy + dy

    def holds_xy(self, pos: Position, x: float, y: float) -> bool:
        """Whether (x, y) lies in a place position's region where it is now."""
        dx, dy = self.shift(pos)
        return pos.contains_xy(x - dx, y - dy)

    def put_on(self, obj: Body, pos: Position, yaw: float, xy: tuple[float, float] | None = None) -> None:
        """Stand an object upright just above a place position (at its centre unless `xy` is given)."""
        x, y = xy if xy is not None else self.center(pos)
        self.put(obj, x, y, pos.surface_z + obj.bottom + 0.001, yaw)
