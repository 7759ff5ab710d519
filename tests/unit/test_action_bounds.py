"""A robot action is bounded in simulated steps and in wall time (robocog.server.world.sim.Budget): a
drive it cannot pay for is refused before the robot moves, one stopped on the way leaves the robot at a
location, and the server's shutdown stops a running action."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from robocog.server.world.sim import SHUTTING_DOWN, ActionLimit
from robocog.server.world.world import World
from tests.hostile_scenes import write_far_corridor


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Iterator[World]:
    with World(write_far_corridor(tmp_path_factory.mktemp("corridor") / "corridor.yaml"), seed=0) as w:
        yield w


def test_a_drive_past_the_step_bound_is_refused_before_the_robot_moves(world: World) -> None:
    world.reset(seed=0)
    steps = world.steps
    path = world.map.shortest_path("Front Door", "Far C")
    assert path is not None
    with pytest.raises(ActionLimit, match=r"would take 120,000 simulated steps, more than the 100,000"), world.action():
        world.travel(path)
    assert world.steps == steps
    assert world.robot_location() == "Front Door"


def test_an_action_past_its_wall_time_stops_with_the_robot_at_a_location(world: World) -> None:
    world.reset(seed=0)
    with pytest.raises(ActionLimit, match=r"took more than 0 s and was stopped"), world.action(wall_s=0.0):
        world.travel(["Front Door", "Far A"])
    assert world.robot_location() == "Front Door"
    assert (world.sim.robot.x, world.sim.robot.y) == (0.0, 0.0)


def test_an_action_past_a_smaller_step_bound_is_stopped(world: World) -> None:
    world.reset(seed=0)
    with (
        pytest.raises(ActionLimit, match=r"would take 30,000 simulated steps, more than the 1,000"),
        world.action(steps=1_000),
    ):
        world.travel(["Front Door", "Far A"])


def test_the_shutdown_stops_a_running_action(world: World) -> None:
    world.reset(seed=0)
    SHUTTING_DOWN.set()
    try:
        with pytest.raises(ActionLimit, match="shutting down"), world.action():
            world.travel(["Front Door", "Far A"])
    finally:
        SHUTTING_DOWN.clear()
    assert world.robot_location() == "Front Door"


def test_outside_an_action_nothing_is_counted(world: World) -> None:
    world.reset(seed=0)
    world.travel(["Front Door", "Far A"])  # 30,000 steps, no action open: no bound
    assert world.robot_location() == "Far A"
