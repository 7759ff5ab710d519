"""Driving a world as the server does, for the world's tests: a session on a world, actions run
through the tools, and the world's state read back (positions, layout, the base as PyBullet has it)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS
from robocog.server.tools.base import Tool
from robocog.server.world.world import World
from robocog.shared.results import ActionResult
from tests.helpers import PAPER_EDGES, PAPER_LOCATIONS, Action, action_args

GRASPABLE = ("cube", "box", "mug")
TOOLS: dict[str, Tool[Any]] = {t.name: t for t in ROBOT_TOOLS}
RANDOMIZE = {"randomize": True}


def session_for(world: World) -> RobotSession:
    """A session on `world` (its memory is never opened)."""
    return RobotSession(SessionConfig(), world=world)


def perform(robot: RobotSession, action: Action) -> ActionResult:
    """Run one (tool name, *arguments) action through the session."""
    arguments: dict[str, Any] = action_args(action)
    result: ActionResult = robot.call(TOOLS[action[0]], **arguments)
    return result


def run_sequence(robot: RobotSession, actions: Sequence[Action]) -> list[ActionResult]:
    """Run the actions one after another; their results."""
    return [perform(robot, a) for a in actions]


def xyz(world: World) -> dict[str, tuple[float, float, float]]:
    """Every object's position."""
    return {name: p.xyz for name, p in world.placements().items()}


def max_xyz_difference(a: Mapping[str, Sequence[float]], b: Mapping[str, Sequence[float]]) -> float:
    """The largest difference of a coordinate between two sets of positions of the same objects."""
    assert a.keys() == b.keys()
    return max(abs(u - v) for name in a for u, v in zip(a[name], b[name], strict=True))


def layout(world: World) -> dict[str, tuple[str | None, str | None]]:
    """The (location, position) of every object resting on a place position."""
    return {name: (p.location, p.position) for name, p in world.placements().items() if p.state == "on_position"}


def base_xy(world: World) -> tuple[float, float]:
    """The robot base's x, y as PyBullet has it (not the robot's bookkeeping)."""
    (x, y, _), _ = world.client.getBasePositionAndOrientation(world.sim.robot.base)
    return x, y


def assert_all_succeeded(results: list[ActionResult], sequence: Sequence[Action]) -> None:
    """Fail naming every action of `sequence` that did not succeed, with its message."""
    failed = [(a, r.message) for a, r in zip(sequence, results, strict=True) if r.status != "success"]
    assert not failed, failed


def expected_neighbours() -> dict[str, set[str]]:
    """The paper's map: each location's neighbours."""
    out: dict[str, set[str]] = {name: set() for name in PAPER_LOCATIONS}
    for a, b in PAPER_EDGES:
        out[a].add(b)
        out[b].add(a)
    return out
