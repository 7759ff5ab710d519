"""Perturbations in physics: a grasp that slips mid-drive, an object someone moves, a container someone
closes, a corridor blocked for a while (the schema: `robocog.shared.perturbations`).

A `Perturber` is armed at each reset with the episode's perturbations and a generator seeded from the
world's seed, so the same seed makes the same things go wrong in the same way. The session tells it
when a robot tool call begins and ends (`before_call`, `after_call`); driving asks it which edge is
blocked and whether the held object slips on the way (`travel`). Each perturbation that happens is a
`PerturbationEvent` in `events`; what it does is physics (a released constraint, a teleported object settling, a joint
driven closed by its motor), and ground truth reads the result like any other.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from robocog.server.world import actions, articulation, containers, truth
from robocog.server.world.actions import ProgressFn
from robocog.server.world.sim import Sim
from robocog.shared.perturbations import Perturbation, PerturbationEvent

#: The stream of the world's seed that perturbations draw from (the world's own generator is untouched).
STREAM = 25
#: What slips falls this far from the location's point (as far as a floor position lies from its
#: location's: within the arm's reach from there).
SLIP_DROP_M = 0.55


@dataclass(frozen=True)
class Trip:
    """How a drive ended: the locations passed (start included), the metres driven, and the blocked
    edge it stopped before, if any (then the robot stands at `path[-1]`, short of the goal)."""

    path: list[str]
    driven_m: float
    blocked: tuple[str, str] | None = None
    for_good: bool = False  # the block never clears, and the world says so (robocog-v2.1's blocks)


#: A block that lasts this many calls or more never clears.
FOR_GOOD_CALLS = 1000


@dataclass
class _Block:
    edge: frozenset[str]
    until_tick: int  # the block lifts when this call (counted since the reset) begins
    spec: Perturbation


@dataclass
class Perturber:
    """One episode's perturbations: those still due, the corridors blocked now, and what happened."""

    pending: list[Perturbation]
    rng: np.random.Generator
    events: list[PerturbationEvent] = field(default_factory=list)
    blocks: list[_Block] = field(default_factory=list)
    call: int = 0  # the episode's call now (what an event records)
    ticks: int = 0  # robot tool calls since the reset (what `at_call` and `duration` count)
    loaded_drives: int = 0
    opened: set[str] = field(default_factory=set)  # the containers the robot opened since the reset

    @classmethod
    def arm(cls, perturbations: list[Perturbation], seed: int | None) -> Perturber:
        return cls(list(perturbations), np.random.default_rng([STREAM, seed if seed is not None else 0]))

    # --- due at a call -----------------------------------------------------------------------------

    def before_call(self, sim: Sim, call: int) -> None:
        """A robot tool call begins (`call`: its number in the episode, what events record): blocks that
        ran out lift, and what is due happens (when the robot is elsewhere, for what someone does
        behind its back). Due times and durations count the calls since the reset, so an episode
        begun later in the same world (T2 after T1) goes on counting."""
        self.call = call
        self.ticks += 1
        for block in [b for b in self.blocks if self.ticks >= b.until_tick]:
            self.blocks.remove(block)
            a, b = block.spec.edge or ("", "")
            self._record(block.spec, f"The way between {a} and {b} is clear again.", edge=(a, b), ended=True)
        self.after_call(sim)

    def after_call(self, sim: Sim) -> None:
        """What is due and waited for the robot to leave happens (also as a call ends: the robot may
        have just driven away)."""
        for p in [p for p in self.pending if p.kind != "slip" and p.when is None and p.at_call <= self.ticks]:
            if self._happen(sim, p):
                self.pending.remove(p)

    def _happen(self, sim: Sim, p: Perturbation) -> bool:
        here = truth.robot_location(sim)
        if p.kind == "block_edge":
            a, b = p.edge or ("", "")
            self.blocks.append(_Block(frozenset((a, b)), self.ticks + p.duration, p))
            self._record(p, f"The way between {a} and {b} is blocked.", edge=(a, b))
            return True
        if p.kind == "close_container":
            name = p.container or ""
            if sim.containers[name].geometry.spec.location == here:
                return False  # someone closes it only while the robot is elsewhere
            if not containers.is_closed(sim, name):
                close(sim, name)
                self._record(p, f"Someone closed the {name.replace('_', ' ')}.", container=name)
            return True
        name = p.object or ""
        where = truth.placement(sim, name)
        if where.state == "held" or where.location == here:
            return False  # someone moves it only when the robot neither holds it nor stands by it
        to = (p.to[0], p.to[1]) if p.to is not None else None
        if to is None or (p.when is not None and truth.occupant(sim, sim.positions[to]) is not None):
            to = self._free_floor(sim, name)  # never onto a position something occupies (robocog-v2.1)
        if to is None:
            return True
        spot = sim.positions[to]
        sim.put_on(sim.objects[name], spot, float(self.rng.uniform(-math.pi, math.pi)))
        sim.settle([sim.objects[name].body])
        xyz = truth.placement(sim, name).xyz
        self._record(p, f"Someone moved the {name} to {to[0]} / {to[1]}.", obj=name, xyz=xyz)
        return True

    def _free_floor(self, sim: Sim, name: str) -> tuple[str, str] | None:
        """A free floor position (not where the object is), drawn from the perturbations' generator."""
        here = truth.placement(sim, name)
        free = [
            key
            for key, pos in sim.positions.items()
            if pos.spec.support == "floor"
            and truth.occupant(sim, pos) is None
            and key != (here.location, here.position)
        ]
        if not free:
            return None
        return free[int(self.rng.integers(len(free)))]

    # --- driving -----------------------------------------------------------------------------------

    def blocked(self, a: str, b: str) -> bool:
        return any(block.edge == frozenset((a, b)) for block in self.blocks)

    def opened_by_robot(self, name: str) -> None:
        """The robot opened the container `name` (what `when: leave` waits for)."""
        self.opened.add(name)

    def set_off(self, sim: Sim, path: list[str]) -> list[Perturbation]:
        """The robot sets off along `path`: what the world's state triggers now happens (`when`): an
        object moved before the robot can get to it, a corridor of the route blocked. What happens
        behind the robot once it has gone (`leave`) is returned, for the drive's end."""
        if len(path) < 2:
            return []
        behind = []
        for p in [p for p in self.pending if p.when is not None]:
            if p.when == "route" and frozenset(p.edge or ()) in {frozenset(e) for e in itertools.pairwise(path)}:
                self.pending.remove(p)
                self._happen(sim, p)
            elif p.when == "approach" and self._heads_for(sim, p.object or "", path) and self._happen(sim, p):
                self.pending.remove(p)
            elif p.when == "leave" and self._leaves(sim, p.container or "", path):
                behind.append(p)
        return behind

    def _leaves(self, sim: Sim, name: str, path: list[str]) -> bool:
        """Whether a drive along `path` takes the robot away from the container `name`, open since the
        robot opened it."""
        if name not in self.opened or containers.is_closed(sim, name):
            return False
        return path[0] == sim.containers[name].geometry.spec.location != path[-1]

    def _heads_for(self, sim: Sim, name: str, path: list[str]) -> bool:
        """Whether a drive along `path` takes the robot to the object `name`: it ends in the object's
        room (or at its location, when it is in no room) or passes where the object lies."""
        where = truth.placement(sim, name)
        if where.location is None or where.state == "held":
            return False
        if where.location in path[1:]:
            return True
        room = _room(sim, where.location)
        return room is not None and _room(sim, path[-1]) == room

    def travel(self, sim: Sim, path: list[str], progress: ProgressFn | None = None) -> Trip:
        """Drive along `path`, stopping before a blocked edge; a slip due on this drive lets go of the
        held object at a location of the way, where it falls beside the robot (`_drop_beside`)."""
        behind = self.set_off(sim, path)
        stop = next((i for i, (a, b) in enumerate(itertools.pairwise(path)) if self.blocked(a, b)), None)
        route = path if stop is None else path[: stop + 1]
        metres = sum(sim.map.distance(a, b) for a, b in itertools.pairwise(route))
        sim.budget.afford(actions.drive_steps(sim, route), f"driving {metres:,.1f} m from {route[0]} to {route[-1]}")
        slip = self._slip_due(sim) if len(route) > 1 else None  # a drive blocked at once is no drive
        total = sum(sim.map.distance(a, b) for a, b in itertools.pairwise(route))
        driven = 0.0
        if slip is not None and total > 0:
            # It slips as the robot arrives at a seeded location of the way (one it passes, or where it
            # is going) and falls to the floor beside it, within the arm's reach from there; the robot
            # drives on. (Let go from the carry pose, above the base, at speed, it bounced off the base
            # and slid on to rest anywhere, out of reach of every location.)
            i = int(self.rng.integers(len(route) - 1))
            driven = actions.drive(sim, route[: i + 2], progress)
            held = sim.grasp.name if sim.grasp else ""
            actions.release(sim)
            spot = route[i + 1]
            self._drop_beside(sim, held, spot)
            driven += actions.drive(sim, route[i + 1 :])
            sim.settle([sim.objects[held].body])
            where = truth.placement(sim, held)
            near = f" near {where.location}" if where.location else ""
            self._record(slip, f"The {held} slipped out of the hand at {spot} and fell{near}.", obj=held, xyz=where.xyz)
        elif len(route) > 1:
            driven = actions.drive(sim, route, progress)
        for p in behind if len(route) > 1 else []:  # a drive blocked at once left nothing behind
            self.pending.remove(p)
            self._happen(sim, p)
        if stop is None:
            return Trip(route, driven)
        edge = frozenset((path[stop], path[stop + 1]))
        lasting = any(
            b.edge == edge and b.spec.when is not None and b.spec.duration >= FOR_GOOD_CALLS for b in self.blocks
        )
        return Trip(route, driven, (path[stop], path[stop + 1]), for_good=lasting)

    def _drop_beside(self, sim: Sim, name: str, location: str) -> None:
        """Put the object that slipped on the floor `SLIP_DROP_M` from `location`'s point, in the first
        of eight directions (from a seeded one) where nothing stands, and let physics settle it."""
        obj = sim.objects[name]
        c = sim.client
        low, high = c.getAABB(obj.body)
        half = [(h - lo) / 2 for lo, h in zip(low, high, strict=True)]
        x0, y0 = sim.map.points[location]
        first = int(self.rng.integers(8))
        for k in range(8):
            angle = math.tau * ((first + k) % 8) / 8
            x, y = x0 + SLIP_DROP_M * math.cos(angle), y0 + SLIP_DROP_M * math.sin(angle)
            box = ([x - half[0], y - half[1], 0.01], [x + half[0], y + half[1], 2 * half[2] + 0.01])
            if not [b for b, _ in c.getOverlappingObjects(*box) or [] if b not in (obj.body, sim.floor)]:
                break
        sim.put(obj, x, y, half[2] + 0.005, float(self.rng.uniform(0, math.tau)))
        sim.settle([obj.body])

    def _slip_due(self, sim: Sim) -> Perturbation | None:
        if sim.grasp is None:
            return None
        self.loaded_drives += 1
        slip = next((p for p in self.pending if p.kind == "slip" and p.on_drive == self.loaded_drives), None)
        if slip is not None:
            self.pending.remove(slip)
        return slip

    def _record(
        self,
        p: Perturbation,
        description: str,
        *,
        obj: str | None = None,
        edge: tuple[str, str] | None = None,
        container: str | None = None,
        xyz: tuple[float, float, float] | None = None,
        ended: bool = False,
    ) -> None:
        self.events.append(
            PerturbationEvent(
                kind=p.kind,
                call=self.call,
                description=description,
                announced=p.announce,
                object=obj,
                container=container,
                edge=edge,
                xyz=None if xyz is None else (round(xyz[0], 3), round(xyz[1], 3), round(xyz[2], 3)),
                ended=ended,
            )
        )


def _room(sim: Sim, location: str) -> str | None:
    """The room whose floor holds `location`'s point, if any (the first in scene order)."""
    x, y = sim.map.points[location]
    return next((r.name for r in sim.scene.rooms if r.x[0] <= x <= r.x[1] and r.y[0] <= y <= r.y[1]), None)


def close(sim: Sim, name: str) -> None:
    """Someone pushes the container `name` shut: its joint's motor drives it closed within its force
    limit (no arm involved) until it is shut or stalls; then it holds where physics left it."""
    box = sim.containers[name]
    for obj in sim.objects.values():
        sim.wake(obj.body)
    containers.hold(sim.client, box, 0.0)
    tolerance = articulation.AT_TARGET_M if box.geometry.joint == "prismatic" else articulation.AT_TARGET_RAD
    start = sim.joint(name)
    budget = math.ceil(abs(start) / containers.speed(box.geometry) / sim.scene.physics.time_step * 2)
    best, since = abs(start), 0
    for _ in range(budget + 2 * articulation.STALL_STEPS):
        sim.step()
        left = abs(sim.joint(name))
        if left <= tolerance:
            break
        if best - left > articulation.STALL_PROGRESS:
            best, since = left, 0
        else:
            since += 1
            if since >= articulation.STALL_STEPS:
                containers.hold(sim.client, box, sim.joint(name))
                break
    sim.settle()
