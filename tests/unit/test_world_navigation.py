"""move_to: the shortest path, forgiving names, where the robot already is, unknown and unreachable
locations, progress per segment.

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

import math

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.tools import move_to
from robocog.server.tools.base import Caller
from robocog.server.world.world import DEFAULT_SCENE, World
from robocog.shared.scene import Location
from robocog.shared.scene_files import load_scene
from tests.helpers import PAPER_LOCATIONS
from tests.unit.world_helpers import base_xy, session_for

# --- move_to -----------------------------------------------------------------------------------


def test_move_to_follows_the_shortest_path_and_arrives(world: World, robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="Kitchen Shelf")
    assert result.status == "success", result.message
    assert result.location == "Kitchen Shelf"
    assert result.path == ["Front Door", "Hallway Area Door", "Kitchen Door", "Kitchen Area Left", "Kitchen Shelf"]
    assert result.distance_m == pytest.approx(3 + 2 + 2 + math.hypot(2, 0.85), abs=1e-3)
    assert world.robot_location() == "Kitchen Shelf"
    assert base_xy(world) == pytest.approx(PAPER_LOCATIONS["Kitchen Shelf"], abs=1e-6)
    assert world.steps > 0


@pytest.mark.parametrize("name", ["kitchen shelf", "KITCHEN_SHELF", "  Kitchen-Shelf "])
def test_move_to_forgives_case_spaces_and_underscores(world: World, robot: RobotSession, name: str) -> None:
    result = robot.call(move_to.TOOL, location=name)
    assert result.status == "success", result.message
    assert result.location == "Kitchen Shelf"
    assert base_xy(world) == pytest.approx(PAPER_LOCATIONS["Kitchen Shelf"], abs=1e-6)


def test_move_to_where_the_robot_already_is(world: World, robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="Front Door")
    assert result.status == "success"
    assert result.path == ["Front Door"]
    assert result.distance_m == 0
    assert "already" in result.message
    assert world.steps == 0


def test_move_to_unknown_location_suggests_close_names(world: World, robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="Kitchen Shelve")
    assert result.status == "failure"
    assert result.error == "unknown_location"
    assert result.suggestions[0] == "Kitchen Shelf"
    assert "Kitchen Shelf" in result.message
    assert result.location == "Front Door"
    assert world.robot_location() == "Front Door"
    assert world.steps == 0


def test_move_to_disconnected_location_reports_no_path() -> None:
    base = load_scene(DEFAULT_SCENE)
    scene = base.model_copy(update={"locations": [*base.locations, Location(name="Garage", x=-3.0, y=0.0)]})
    with World(scene) as w:
        result = session_for(w).call(move_to.TOOL, location="Garage")
        assert result.status == "failure"
        assert result.error == "no_path"
        assert "Front Door" in result.message and "Garage" in result.message
        assert w.robot_location() == "Front Door"
        assert w.steps == 0


def test_move_to_reports_progress_per_segment(robot: RobotSession) -> None:
    calls: list[tuple[float, float, str]] = []
    progress = lambda done, total, msg: calls.append((done, total, msg))  # noqa: E731
    result = robot.invoke(move_to.TOOL, {"location": "Living Room"}, Caller(progress=progress))
    assert result.status == "success"
    assert [c[:2] for c in calls] == [(1, 3), (2, 3), (3, 3)]
    assert calls[-1][2].endswith("Living Room")
