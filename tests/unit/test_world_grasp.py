"""grab and place: the object attached to the hand and put on a position, and every failure the paper
names (out of reach, already holding, nothing held, occupied, not graspable), checked against a snapshot.

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

import math

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.tools import grab, move_to, place
from robocog.server.world.actions import Reach
from robocog.server.world.world import World
from robocog.shared.results import ObjectPlacement
from tests.helpers import T1_SEQUENCE, Action, check_snapshot
from tests.unit.world_helpers import assert_all_succeeded, base_xy, perform, run_sequence

# --- grab --------------------------------------------------------------------------------------


def test_grab_attaches_the_object_to_the_hand(world: World, robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="cube")
    assert result.status == "success", result.message
    assert result.message == "Grabbed the cube from Front Door / floor."
    assert result.holding == "cube"
    assert world.holding == "cube"
    assert world.placement("cube").state == "held"


def test_grabbed_object_travels_with_the_robot(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    assert robot.call(move_to.TOOL, location="Kitchen Shelf").status == "success"
    x, y, z = world.placement("cube").xyz
    bx, by = base_xy(world)
    assert math.hypot(x - bx, y - by) < 0.5
    assert z > 0.3  # carried above the base, not dragged along the floor


def test_grab_unknown_object_suggests_close_names(world: World, robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="cub")
    assert result.status == "failure"
    assert result.error == "unknown_object"
    assert result.suggestions == ["cube"]
    assert "cube" in result.message
    assert world.holding is None


def test_grab_object_at_another_location_is_out_of_reach(world: World, robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="mug")
    assert result.status == "failure"
    assert result.error == "out_of_reach"
    assert "Kitchen Table" in result.message
    assert world.holding is None
    assert world.placement("mug").position == "middle"


def test_grab_while_holding_fails(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    assert robot.call(move_to.TOOL, location="Living Room").status == "success"
    result = robot.call(grab.TOOL, object="box")
    assert result.status == "failure"
    assert result.error == "already_holding"
    assert result.holding == "cube"
    assert "cube" in result.message
    assert world.holding == "cube"
    assert world.placement("box").state == "on_position"


def test_grab_tv_is_not_graspable(world: World, robot: RobotSession) -> None:
    assert robot.call(move_to.TOOL, location="Living Room TV").status == "success"
    before = world.placement("tv").xyz
    result = robot.call(grab.TOOL, object="tv")
    assert result.status == "failure"
    assert result.error == "not_graspable"
    assert world.holding is None
    assert world.placement("tv").xyz == pytest.approx(before, abs=1e-3)


@pytest.mark.parametrize(
    ("reach", "message"),
    [
        (
            Reach(ok=False, failure="unreachable", gap_m=0.4),
            "The arm cannot reach the cube from where the robot stands (0.40 m short).",
        ),
        (
            Reach(ok=False, failure="missed", gap_m=0.12),
            "The hand stopped 0.12 m from the cube; it could not be grasped from here.",
        ),
    ],
)
def test_grab_words_a_motion_that_falls_short(
    world: World, robot: RobotSession, monkeypatch: pytest.MonkeyPatch, reach: Reach, message: str
) -> None:
    monkeypatch.setattr(world, "pick", lambda name: reach)
    result = robot.call(grab.TOOL, object="cube")
    assert (result.status, result.error, result.message) == ("failure", "out_of_reach", message)
    assert (result.object, result.holding) == ("cube", None)


# --- place -------------------------------------------------------------------------------------


def test_place_puts_the_object_on_the_position_where_it_stays(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    assert robot.call(move_to.TOOL, location="Kitchen Shelf").status == "success"
    result = robot.call(place.TOOL, location="Kitchen Shelf", position="top")
    assert result.status == "success", result.message
    assert world.holding is None
    placed = world.placement("cube")
    assert (placed.state, placed.location, placed.position) == ("on_position", "Kitchen Shelf", "top")
    for _ in range(240):  # two more simulated seconds under gravity
        world.sim.step()
    after = world.placement("cube")
    assert (after.state, after.location, after.position) == ("on_position", "Kitchen Shelf", "top")
    assert after.resting
    assert after.xyz == pytest.approx(placed.xyz, abs=0.01)


def test_place_with_nothing_held_fails(robot: RobotSession) -> None:
    result = robot.call(place.TOOL, location="Front Door", position="floor")
    assert result.status == "failure"
    assert result.error == "nothing_held"
    assert (result.object, result.location, result.position, result.holding) == (None, "Front Door", "floor", None)


def test_place_away_from_the_location_fails(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    result = robot.call(place.TOOL, location="Kitchen Shelf", position="top")
    assert result.status == "failure"
    assert result.error == "not_at_location"
    assert "Front Door" in result.message and "Kitchen Shelf" in result.message
    assert world.holding == "cube"


def test_place_on_unknown_position_lists_the_positions(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    assert robot.call(move_to.TOOL, location="Kitchen Shelf").status == "success"
    result = robot.call(place.TOOL, location="Kitchen Shelf", position="ceiling")
    assert result.status == "failure"
    assert result.error == "unknown_position"
    for name in ("top", "middle", "bottom"):
        assert name in result.message
    assert set(result.suggestions) <= {"top", "middle", "bottom"}
    assert result.suggestions
    assert world.holding == "cube"


def test_place_at_unknown_location_fails(world: World, robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    result = robot.call(place.TOOL, location="Kitchen Shelve", position="top")
    assert result.status == "failure"
    assert result.error == "unknown_location"
    assert "Kitchen Shelf" in result.suggestions
    assert (result.location, result.position, result.holding) == ("Kitchen Shelve", "top", "cube")
    assert world.holding == "cube"


def test_place_on_occupied_position_names_occupant_and_free_positions(world: World, robot: RobotSession) -> None:
    setup = T1_SEQUENCE[1:7]  # the cube onto the top layer, then back at the shelf with the box
    assert_all_succeeded(run_sequence(robot, setup), setup)
    result = robot.call(place.TOOL, location="Kitchen Shelf", position="top")
    assert result.status == "failure"
    assert result.error == "position_occupied"
    assert "cube" in result.message
    assert "middle" in result.message and "bottom" in result.message
    assert sorted(result.suggestions) == ["bottom", "middle"]
    assert world.holding == "box"
    assert world.placement("cube").position == "top"


def test_place_words_a_motion_that_falls_short(
    world: World, robot: RobotSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    monkeypatch.setattr(world, "put_down", lambda location, position: Reach(ok=False, failure="unreachable", gap_m=0.3))
    result = robot.call(place.TOOL, location="Front Door", position="floor")
    assert (result.status, result.error) == ("failure", "out_of_reach")
    assert result.message == "The arm cannot reach the floor position of Front Door (0.30 m short)."
    assert (result.object, result.location, result.position, result.holding) == ("cube", "Front Door", "floor", "cube")


def test_place_reports_where_a_released_object_ended(
    world: World, robot: RobotSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    rolled = ObjectPlacement(object="cube", state="loose", location="Front Door", xyz=(0.5, 0.0, 0.05), resting=False)
    monkeypatch.setattr(
        world, "put_down", lambda location, position: Reach(ok=False, failure="landed_elsewhere", placement=rolled)
    )
    result = robot.call(place.TOOL, location="front door", position="FLOOR")
    assert (result.status, result.error) == ("failure", "place_failed")
    assert result.message == (
        "The cube was released but did not come to rest on Front Door / floor; it is near Front Door."
    )
    assert (result.object, result.location, result.position, result.holding) == ("cube", "Front Door", "floor", None)


#: Every precondition of the world tools, one after another from the paper's start (and the moves between).
PRECONDITIONS: tuple[Action, ...] = (
    ("move_to", "Kitchen Shelve"),
    ("grab", "cub"),
    ("grab", "mug"),
    ("place", "Front Door", "floor"),
    ("grab", "cube"),
    ("grab", "cube"),
    ("place", "Kitchen Shelf", "top"),
    ("place", "Kitchen Shelve", "top"),
    ("place", "Front Door", "ceiling"),
    ("move_to", "Living Room"),
    ("grab", "box"),
    ("place", "Living Room", "floor"),
    ("move_to", "Kitchen Door"),
    ("place", "Kitchen Door", "floor"),
    ("move_to", "Hallway Area Door"),
    ("place", "Hallway Area Door", "floor"),
    ("move_to", "Living Room TV"),
    ("grab", "tv"),
)


def test_world_tool_results_match_the_snapshot(robot: RobotSession) -> None:
    results = [perform(robot, action).model_dump(mode="json") for action in PRECONDITIONS]
    errors = [r["error"] for r in results]
    assert set(errors) >= {
        "unknown_location",
        "unknown_object",
        "out_of_reach",
        "nothing_held",
        "already_holding",
        "not_at_location",
        "unknown_position",
        "position_occupied",
        "not_graspable",
    }, errors
    check_snapshot("world_tool_results", {"results": [[*a, r] for a, r in zip(PRECONDITIONS, results, strict=True)]})
