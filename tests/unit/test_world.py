"""The simulated world and the world tools: start state, actions and their failures, the paper's tasks,
invariants, determinism.

Real PyBullet throughout (no mocks). World-level behaviour (building, reset, ground truth, the
physical primitives) is tested on the `World` API; the actions' results and failure messages through
the tools, called with a `RobotSession` as the server calls them. Most tests share one module-scoped
`World` that the `world` fixture resets before each test; tests that need their own worlds
(determinism, independence, custom scenes) build them.
"""

from __future__ import annotations

import math
import random
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import pytest

from robocog.server.config import SessionConfig
from robocog.server.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS, grab, look_around, move_to, place
from robocog.server.tools.base import Caller, Tool
from robocog.server.world.actions import Reach
from robocog.server.world.describe import describe
from robocog.server.world.navigation import closest, strip_articles
from robocog.server.world.tasks import evaluate, task_catalogue
from robocog.server.world.world import DEFAULT_SCENE, World
from robocog.shared.errors import WorldError
from robocog.shared.results import ActionResult, ObjectPlacement
from robocog.shared.scene import Location, load_scene
from tests.helpers import (
    PAPER_EDGES,
    PAPER_LOCATIONS,
    PAPER_POSITIONS,
    T1_SEQUENCE,
    T2_SEQUENCE,
    Action,
    action_args,
    check_snapshot,
)

GRASPABLE = ("cube", "box", "mug")
TOOLS: dict[str, Tool[Any]] = {t.name: t for t in ROBOT_TOOLS}
RANDOMIZE = {"randomize": True}


# --- fixtures and helpers ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def shared_world() -> Iterator[World]:
    with World() as w:
        yield w


@pytest.fixture
def world(shared_world: World) -> World:
    """The module's world, reset to the paper's static start."""
    shared_world.reset()
    return shared_world


@pytest.fixture
def robot(world: World) -> RobotSession:
    """A session on the module's world (its memory is never opened)."""
    return session_for(world)


def session_for(world: World) -> RobotSession:
    return RobotSession(SessionConfig(), world=world)


def perform(robot: RobotSession, action: Action) -> ActionResult:
    """Run one (tool name, *arguments) action through the session."""
    arguments: dict[str, Any] = action_args(action)
    result: ActionResult = robot.call(TOOLS[action[0]], **arguments)
    return result


def run_sequence(robot: RobotSession, actions: Sequence[Action]) -> list[ActionResult]:
    return [perform(robot, a) for a in actions]


def xyz(world: World) -> dict[str, tuple[float, float, float]]:
    return {name: p.xyz for name, p in world.placements().items()}


def max_xyz_difference(a: Mapping[str, Sequence[float]], b: Mapping[str, Sequence[float]]) -> float:
    assert a.keys() == b.keys()
    return max(abs(u - v) for name in a for u, v in zip(a[name], b[name], strict=True))


def layout(world: World) -> dict[str, tuple[str | None, str | None]]:
    return {name: (p.location, p.position) for name, p in world.placements().items() if p.state == "on_position"}


def base_xy(world: World) -> tuple[float, float]:
    """The robot base's x, y as PyBullet has it (not the robot's bookkeeping)."""
    (x, y, _), _ = world.client.getBasePositionAndOrientation(world.sim.robot.base)
    return x, y


def assert_all_succeeded(results: list[ActionResult], sequence: Sequence[Action]) -> None:
    failed = [(a, r.message) for a, r in zip(sequence, results, strict=True) if r.status != "success"]
    assert not failed, failed


def expected_neighbours() -> dict[str, set[str]]:
    out: dict[str, set[str]] = {name: set() for name in PAPER_LOCATIONS}
    for a, b in PAPER_EDGES:
        out[a].add(b)
        out[b].add(a)
    return out


# --- start state -------------------------------------------------------------------------------


def test_start_state_objects_rest_where_the_paper_puts_them(world: World) -> None:
    p = world.placements()
    assert (p["cube"].state, p["cube"].location, p["cube"].position) == ("on_position", "Front Door", "floor")
    assert (p["box"].state, p["box"].location, p["box"].position) == ("on_position", "Living Room", "floor")
    assert (p["mug"].state, p["mug"].location, p["mug"].position) == ("on_position", "Kitchen Table", "middle")
    for name in GRASPABLE:
        assert p[name].resting, name


def test_start_state_tv_is_loose_near_living_room_tv(world: World) -> None:
    tv = world.placement("tv")
    assert tv.state == "loose"
    assert tv.location == "Living Room TV"
    assert tv.resting  # on its table, not falling
    assert math.hypot(tv.xyz[0] - 8.0, tv.xyz[1] + 4.5) < 1.3
    assert not world.object_spec("tv").graspable


def test_start_state_robot_at_front_door_holding_nothing(world: World) -> None:
    assert world.robot_location() == "Front Door"
    assert world.holding is None
    assert base_xy(world) == pytest.approx((0.0, 0.0), abs=1e-6)
    state = world.state()
    assert state.robot.location == "Front Door"
    assert state.robot.holding is None
    assert state.steps == world.steps == 0


# --- ground truth ------------------------------------------------------------------------------


def test_names_come_in_scene_order(world: World) -> None:
    assert world.object_names == [o.name for o in world.scene.objects]
    assert world.position_names("Kitchen Shelf") == ["top", "middle", "bottom"]
    assert world.position_names("Kitchen Door") == []
    assert world.object_spec("mug").name == "mug"


def test_occupants_and_the_state_agree_with_the_placements(world: World) -> None:
    assert world.occupant("Front Door", "floor") == "cube"
    assert world.occupant("Front Door", "floor", ignore="cube") is None
    assert world.occupant("Kitchen Shelf", "top") is None
    state = world.state()
    assert [p.object for p in state.objects] == world.object_names
    taken = {(p.location, p.position): p.occupied_by for p in state.positions if p.occupied_by}
    assert taken == {
        ("Front Door", "floor"): "cube",
        ("Living Room", "floor"): "box",
        ("Kitchen Table", "middle"): "mug",
    }
    assert {(p.location, p.position) for p in state.positions} == {
        (loc, pos) for loc, names in PAPER_POSITIONS.items() for pos in names
    }


def test_the_held_object_occupies_no_position(world: World) -> None:
    assert world.pick("cube").ok
    assert world.holding == "cube"
    assert world.placement("cube").state == "held"
    assert world.placement("cube").location == "Front Door"
    assert world.occupant("Front Door", "floor") is None
    assert world.state().robot.holding == "cube"


# --- the physical primitives -------------------------------------------------------------------


def test_drive_follows_the_given_path_and_reports_each_segment(world: World) -> None:
    calls: list[tuple[float, float, str]] = []
    driven = world.drive(["Front Door", "Hallway Area Door"], lambda *c: calls.append(c))
    assert driven == pytest.approx(3.0)
    assert calls == [(1, 1, "reached Hallway Area Door")]
    assert world.robot_location() == "Hallway Area Door"
    assert base_xy(world) == pytest.approx(PAPER_LOCATIONS["Hallway Area Door"], abs=1e-6)
    assert world.steps > 0


def test_pick_out_of_the_arms_reach_moves_nothing(world: World) -> None:
    reach = world.pick("mug")  # on the kitchen table, metres away
    assert (reach.ok, reach.failure) == (False, "unreachable")
    assert reach.gap_m > world.robot_spec.grasp_threshold
    assert world.holding is None
    assert world.steps == 0


def test_put_down_reports_where_the_object_came_to_rest(world: World) -> None:
    assert world.pick("cube").ok
    far = world.put_down("Kitchen Shelf", "top")
    assert (far.ok, far.failure) == (False, "unreachable")
    assert world.holding == "cube"
    reach = world.put_down("Front Door", "floor")
    assert reach.ok and reach.failure is None
    assert reach.placement is not None
    assert (reach.placement.state, reach.placement.location, reach.placement.position) == (
        "on_position",
        "Front Door",
        "floor",
    )
    assert world.holding is None


# --- look_around -------------------------------------------------------------------------------


def test_look_around_reports_robot_and_hand(robot: RobotSession) -> None:
    result = robot.call(look_around.TOOL)
    assert result.status == "success"
    assert result.location == "Front Door"
    assert result.holding is None
    assert "Front Door" in result.message and "holding nothing" in result.message


def test_look_around_lists_every_location_with_the_papers_neighbours(robot: RobotSession) -> None:
    views = {v.name: v for v in robot.call(look_around.TOOL).locations}
    assert set(views) == set(PAPER_LOCATIONS)
    for name, neighbours in expected_neighbours().items():
        assert set(views[name].neighbours) == neighbours, name


def test_look_around_lists_objects_per_location(robot: RobotSession) -> None:
    views = {v.name: v for v in robot.call(look_around.TOOL).locations}
    expected = {"Front Door": ["cube"], "Living Room": ["box"], "Kitchen Table": ["mug"], "Living Room TV": ["tv"]}
    for name, view in views.items():
        assert sorted(view.objects) == expected.get(name, []), name


def test_look_around_lists_place_positions_with_occupants(robot: RobotSession) -> None:
    views = {v.name: v for v in robot.call(look_around.TOOL).locations}
    occupants = {(name, pos.name): pos.occupied_by for name, view in views.items() for pos in view.place_positions}
    expected_keys = {(loc, pos) for loc, names in PAPER_POSITIONS.items() for pos in names}
    assert set(occupants) == expected_keys
    taken = {("Front Door", "floor"): "cube", ("Living Room", "floor"): "box", ("Kitchen Table", "middle"): "mug"}
    for key, occupant in occupants.items():
        assert occupant == taken.get(key), key


def test_look_around_changes_nothing(world: World, robot: RobotSession) -> None:
    before, steps = xyz(world), world.steps
    robot.call(look_around.TOOL)
    assert world.steps == steps
    assert xyz(world) == before


def test_look_around_reports_the_held_object(robot: RobotSession) -> None:
    assert robot.call(grab.TOOL, object="cube").status == "success"
    result = robot.call(look_around.TOOL)
    assert result.holding == "cube"
    assert "holding the cube" in result.message
    # A held object is in the hand, not lying at a location.
    assert all("cube" not in v.objects for v in result.locations)


# --- the environment description (robocog://world/description) ---------------------------------

START_DESCRIPTION = """\
These are the locations in the world:
- Front Door
  - Objects here:
    - cube
  - Place positions here:
    - floor: occupied by cube
  - Connected locations:
    - Hallway Area Door
- Hallway Area Door
  - Objects here: none
  - Place positions here:
    - floor: empty
  - Connected locations:
    - Front Door
    - Kitchen Door
    - Living Room Door
- Kitchen Door
  - Objects here: none
  - Place positions here: none
  - Connected locations:
    - Hallway Area Door
    - Kitchen Area Left
- Living Room Door
  - Objects here: none
  - Place positions here: none
  - Connected locations:
    - Hallway Area Door
    - Living Room
- Living Room
  - Objects here:
    - box
  - Place positions here:
    - floor: occupied by box
  - Connected locations:
    - Living Room Door
    - Living Room TV
- Living Room TV
  - Objects here:
    - tv
  - Place positions here: none
  - Connected locations:
    - Living Room
- Kitchen Area Left
  - Objects here: none
  - Place positions here:
    - floor: empty
  - Connected locations:
    - Kitchen Door
    - Kitchen Shelf
    - Kitchen Table
- Kitchen Shelf
  - Objects here: none
  - Place positions here:
    - top: empty
    - middle: empty
    - bottom: empty
  - Connected locations:
    - Kitchen Area Left
- Kitchen Table
  - Objects here:
    - mug
  - Place positions here:
    - middle: occupied by mug
  - Connected locations:
    - Kitchen Area Left
You are at: Front Door"""


def test_the_description_of_the_start_state(world: World) -> None:
    assert describe(world) == START_DESCRIPTION
    assert describe(world) == START_DESCRIPTION  # deterministic, and reading changes nothing
    assert world.steps == 0


def location_block(text: str, name: str) -> str:
    """The lines of the description under the location `name` (its heading excluded)."""
    lines = text.splitlines()
    start = lines.index(f"- {name}") + 1
    end = next(i for i in range(start, len(lines)) if not lines[i].startswith("  "))
    return "\n".join(lines[start:end])


def test_the_description_follows_the_world(world: World, robot: RobotSession) -> None:
    """Objects where they are now, the held one in the hand, real occupancy, the robot's location."""
    run_sequence(robot, T1_SEQUENCE[:3])  # the cube in the hand, at the Kitchen Shelf
    text = describe(world)
    assert location_block(text, "Front Door").startswith(
        "  - Objects here: none\n  - Place positions here:\n    - floor: empty"
    )
    assert location_block(text, "Kitchen Shelf").startswith("  - Objects here:\n    - cube (in your hand)\n")
    assert text.endswith("You are at: Kitchen Shelf")
    run_sequence(robot, T1_SEQUENCE[3:4])
    text = describe(world)
    assert "(in your hand)" not in text
    for view in robot.call(look_around.TOOL).locations:  # the same occupancy as look_around's
        block = location_block(text, view.name)
        for pos in view.place_positions:
            assert f"    - {pos.name}: {f'occupied by {pos.occupied_by}' if pos.occupied_by else 'empty'}" in block
    assert "    - top: occupied by cube" in location_block(text, "Kitchen Shelf")


# --- names a model gives -----------------------------------------------------------------------

LOCATIONS = list(PAPER_LOCATIONS)
OBJECTS = ["cube", "box", "mug", "tv"]


@pytest.mark.parametrize(
    ("name", "known", "expected"),
    [
        ("the shelf", LOCATIONS, ["Kitchen Shelf"]),  # article stripped, word overlap
        ("shelf", LOCATIONS, ["Kitchen Shelf"]),
        ("shelve", LOCATIONS, ["Kitchen Shelf"]),  # a misspelt word still overlaps
        ("Kitchen Shelve", LOCATIONS, ["Kitchen Shelf"]),  # a misspelling of the whole name
        ("the front dor", LOCATIONS, ["Front Door"]),
        ("to the kitchen shelf", LOCATIONS, ["Kitchen Shelf"]),
        ("cub", OBJECTS, ["cube"]),
        ("the cube", OBJECTS, ["cube"]),
        ("red cube", OBJECTS, ["cube"]),
        ("mugs", OBJECTS, ["mug"]),
        ("table", OBJECTS, []),  # letters in common are not enough ("cube")
        ("cup", OBJECTS, []),
        ("garage", LOCATIONS, []),
        ("the", LOCATIONS, []),
        ("mug", LOCATIONS, []),
    ],
)
def test_closest_suggests_only_names_plausibly_meant(name: str, known: list[str], expected: list[str]) -> None:
    assert closest(name, known) == expected


def test_closest_ranks_and_caps_ambiguous_words() -> None:
    kitchen = closest("kitchen", LOCATIONS)
    assert len(kitchen) == 3 and all(k.startswith("Kitchen") for k in kitchen)
    assert closest("living room tv table", LOCATIONS) == ["Living Room TV"]


def test_strip_articles() -> None:
    assert strip_articles("  The Kitchen_Shelf ") == "kitchen shelf"
    assert strip_articles("a mug") == "mug"
    assert strip_articles("an") == ""


def test_grab_a_location_says_it_is_a_location(world: World, robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="table")
    assert (result.status, result.error, result.suggestions) == ("failure", "unknown_object", [])
    assert result.message.startswith("'table' is not an object; Kitchen Table is a location.")
    assert "Did you mean" not in result.message
    result = robot.call(grab.TOOL, object="the Kitchen Shelf")
    assert result.message.startswith("'the Kitchen Shelf' is not an object; Kitchen Shelf is a location.")
    assert world.holding is None


def test_grab_furniture_says_where_it_stands(robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="tv table")  # not the tv: the table it stands on
    assert (result.error, result.suggestions) == ("unknown_object", [])
    assert result.message.startswith("'tv table' is not an object; the tv table is furniture at Living Room TV.")


def test_grab_with_an_article_suggests_the_object(robot: RobotSession) -> None:
    result = robot.call(grab.TOOL, object="the cube")
    assert (result.error, result.suggestions) == ("unknown_object", ["cube"])
    assert "Did you mean 'cube'?" in result.message


def test_move_to_the_shelf_suggests_the_kitchen_shelf(world: World, robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="the shelf")
    assert (result.error, result.suggestions) == ("unknown_location", ["Kitchen Shelf"])
    assert "Did you mean 'Kitchen Shelf'?" in result.message
    assert world.steps == 0


def test_move_to_an_object_says_it_is_an_object(world: World, robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="the mug")
    assert (result.error, result.suggestions) == ("unknown_location", [])
    assert result.message.startswith("'the mug' is an object, not a location; it is at Kitchen Table.")
    robot.call(grab.TOOL, object="cube")
    placed = robot.call(place.TOOL, location="cube", position="floor")
    assert placed.message.startswith("'cube' is an object, not a location; the robot is holding it.")
    assert world.steps > 0


def test_move_to_furniture_suggests_its_location(robot: RobotSession) -> None:
    result = robot.call(move_to.TOOL, location="tv table")
    assert (result.error, result.suggestions) == ("unknown_location", ["Living Room TV"])
    assert "the tv table stands at Living Room TV" in result.message


def test_furniture_stands_at_the_location_it_serves(world: World) -> None:
    assert world.furniture_locations() == {
        "kitchen_shelf": "Kitchen Shelf",
        "kitchen_table": "Kitchen Table",
        "tv_table": "Living Room TV",
    }


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


# --- the paper's tasks -------------------------------------------------------------------------


def test_t1_is_false_at_the_start(world: World) -> None:
    verdict = evaluate(task_catalogue()["T1"], world.placements())
    assert not verdict.success


def test_t2_is_false_at_the_start(world: World) -> None:
    start = world.placements()
    assert not evaluate(task_catalogue()["T2"], start, start).success


def test_t1_sequence_satisfies_t1(world: World, robot: RobotSession) -> None:
    assert_all_succeeded(run_sequence(robot, T1_SEQUENCE), T1_SEQUENCE)
    verdict = evaluate(task_catalogue()["T1"], world.placements())
    assert verdict.success, verdict.reason
    assert {name: world.placement(name).position for name in GRASPABLE} == {
        "cube": "top",
        "box": "middle",
        "mug": "bottom",
    }


def test_t2_sequence_after_t1_satisfies_t2(world: World, robot: RobotSession) -> None:
    t2 = task_catalogue()["T2"]
    assert_all_succeeded(run_sequence(robot, T1_SEQUENCE), T1_SEQUENCE)
    baseline = world.placements()
    assert not evaluate(t2, world.placements(), baseline).success  # nothing swapped yet
    assert_all_succeeded(run_sequence(robot, T2_SEQUENCE), T2_SEQUENCE)
    verdict = evaluate(t2, world.placements(), baseline)
    assert verdict.success, verdict.reason
    assert world.placement("mug").position == baseline["cube"].position
    assert world.placement("cube").position == baseline["mug"].position


# --- invariants under random action sequences --------------------------------------------------

_LOCATIONS = list(PAPER_LOCATIONS)
_BAD_LOCATIONS = ["Garage", "Kitchen Shelve", "kitchen shelf"]
_OBJECTS = ["cube", "box", "mug", "tv"]
_BAD_OBJECTS = ["banana", "cub"]
_POSITIONS = ["top", "middle", "bottom", "floor", "ceiling"]


def _random_action(rng: random.Random, world: World) -> Action:
    """A random action over valid and invalid names, biased towards ones that can succeed."""
    here = world.robot_location()
    loose = {n: p for n, p in world.placements().items() if p.state != "held"}
    kind = rng.choice(["look_around", "move_to", "move_to", "grab", "grab", "place", "place"])
    if kind == "place" and world.holding is None and rng.random() < 0.7:
        kind = "grab"
    elif kind == "grab" and world.holding is not None and rng.random() < 0.7:
        kind = "place"
    if kind == "look_around":
        return ("look_around",)
    if kind == "move_to":
        if rng.random() < 0.15:
            return ("move_to", rng.choice(_BAD_LOCATIONS))
        targets = [p.location for p in loose.values() if p.location] + _LOCATIONS
        return ("move_to", rng.choice(targets))
    if kind == "grab":
        if rng.random() < 0.15:
            return ("grab", rng.choice(_BAD_OBJECTS))
        near = [n for n, p in loose.items() if p.location == here]
        return ("grab", rng.choice(near if near and rng.random() < 0.7 else _OBJECTS))
    location = here if rng.random() < 0.8 else rng.choice(_LOCATIONS + _BAD_LOCATIONS)
    own = sorted(PAPER_POSITIONS.get(location, set()))
    return ("place", location, rng.choice(own if own and rng.random() < 0.7 else _POSITIONS))


def _check_invariants(world: World, context: str) -> None:
    placements: dict[str, ObjectPlacement] = world.placements()
    assert set(placements) == {o.name for o in world.scene.objects}, context
    for name, p in placements.items():
        assert all(math.isfinite(v) for v in p.xyz), (context, name, p.xyz)
        assert p.xyz[2] > -0.05, (context, name, p.xyz)
    taken = Counter((p.location, p.position) for p in placements.values() if p.state == "on_position")
    assert all(n == 1 for n in taken.values()), (context, taken)
    held = [name for name, p in placements.items() if p.state == "held"]
    assert held == ([world.holding] if world.holding else []), (context, held, world.holding)
    if world.holding:
        x, y, _ = placements[world.holding].xyz
        bx, by = base_xy(world)
        assert math.hypot(x - bx, y - by) < 0.6, (context, world.holding, (x, y), (bx, by))


@pytest.mark.parametrize("seed", [10, 11, 14])
def test_invariants_hold_after_every_action_of_a_random_sequence(world: World, robot: RobotSession, seed: int) -> None:
    rng = random.Random(seed)
    outcomes: Counter[tuple[str, str]] = Counter()
    for i in range(15):
        action = _random_action(rng, world)
        result = perform(robot, action)
        outcomes[(action[0], result.status)] += 1
        _check_invariants(world, f"seed {seed}, action {i}: {action} -> {result.status} {result.error}")
    # The sequence did exercise the physics (not only failures).
    assert outcomes[("grab", "success")] >= 1 and outcomes[("place", "success")] >= 1, outcomes


# --- determinism -------------------------------------------------------------------------------


def _scripted_actions(world: World) -> tuple[Action, ...]:
    """Five actions that move an object, whatever the (randomised) layout."""
    cube = world.placement("cube")
    free_shelf = next(
        pos for pos in ("top", "middle", "bottom") if ("Kitchen Shelf", pos) not in set(layout(world).values())
    )
    return (
        ("move_to", str(cube.location)),
        ("grab", "cube"),
        ("move_to", "Kitchen Shelf"),
        ("place", "Kitchen Shelf", free_shelf),
        ("move_to", "Living Room"),
    )


def test_same_seed_gives_identical_worlds_at_start() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=7, options=RANDOMIZE) as b:
        assert layout(a) == layout(b)
        assert max_xyz_difference(xyz(a), xyz(b)) <= 1e-9


def test_same_seed_gives_identical_worlds_after_the_same_actions() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=7, options=RANDOMIZE) as b:
        actions = _scripted_actions(a)
        results_a = [r.model_dump() for r in run_sequence(session_for(a), actions)]
        results_b = [r.model_dump() for r in run_sequence(session_for(b), actions)]
        assert results_a == results_b
        assert all(r["status"] == "success" for r in results_a), results_a
        assert a.steps == b.steps
        assert max_xyz_difference(xyz(a), xyz(b)) <= 1e-9


def test_different_seeds_give_different_layouts() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=8, options=RANDOMIZE) as b:
        assert layout(a) != layout(b)


def test_randomized_layout_puts_each_item_resting_on_its_own_position() -> None:
    with World(seed=3, options=RANDOMIZE) as w:
        placements = w.placements()
        for name in GRASPABLE:
            assert placements[name].state == "on_position", placements[name]
            assert placements[name].resting
        assert len({layout(w)[name] for name in GRASPABLE}) == len(GRASPABLE)
        assert w.robot_location() == "Front Door"


def test_reset_with_the_same_seed_twice_gives_the_same_layout() -> None:
    with World() as w:
        w.reset(seed=11, options=RANDOMIZE)
        first, first_steps = xyz(w), w.steps
        w.reset(seed=11, options=RANDOMIZE)
        assert max_xyz_difference(first, xyz(w)) <= 1e-9
        assert w.steps == first_steps


def test_reset_without_a_seed_continues_the_worlds_generator() -> None:
    with World(seed=7) as a, World(seed=7) as b:
        a.reset(options=RANDOMIZE)
        b.reset(options=RANDOMIZE)
        first = layout(a)
        assert first == layout(b)  # the same generator state: the same draw
        a.reset(options=RANDOMIZE)
        b.reset(seed=7, options=RANDOMIZE)
        assert layout(b) == first  # reseeded: the first draw again
        assert a.seed == b.seed == 7


def test_reset_restores_static_setup_after_moves(world: World) -> None:
    reference = xyz(world)
    robot = session_for(world)
    assert robot.call(move_to.TOOL, location="Kitchen Table").status == "success"
    world.reset(seed=5, options=RANDOMIZE)
    robot.call(move_to.TOOL, location="Living Room")
    world.reset()
    assert world.robot_location() == "Front Door"
    assert base_xy(world) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert world.steps == 0
    assert max_xyz_difference(reference, xyz(world)) <= 1e-6


def test_reset_restores_static_setup_after_the_t1_sequence() -> None:
    with World() as fresh, World() as w:
        assert_all_succeeded(run_sequence(session_for(w), T1_SEQUENCE), T1_SEQUENCE)
        w.reset()
        assert w.holding is None
        assert w.robot_location() == "Front Door"
        assert w.steps == 0
        assert layout(w) == layout(fresh)
        assert max_xyz_difference(xyz(fresh), xyz(w)) <= 1e-6


def test_reset_with_a_seed_after_an_episode_matches_a_fresh_world_with_that_seed() -> None:
    with World(seed=7, options=RANDOMIZE) as fresh, World() as used:
        assert_all_succeeded(run_sequence(session_for(used), T1_SEQUENCE), T1_SEQUENCE)
        used.reset(seed=7, options=RANDOMIZE)
        assert layout(used) == layout(fresh)
        assert max_xyz_difference(xyz(fresh), xyz(used)) <= 1e-9


def test_reset_with_the_same_seed_twice_after_earlier_resets_gives_the_same_layout() -> None:
    with World() as w:
        robot = session_for(w)
        assert robot.call(move_to.TOOL, location="Kitchen Table").status == "success"
        w.reset(seed=5, options=RANDOMIZE)
        assert robot.call(move_to.TOOL, location="Living Room").status == "success"
        w.reset()
        w.reset(seed=11, options=RANDOMIZE)
        first = xyz(w)
        w.reset(seed=11, options=RANDOMIZE)
        assert max_xyz_difference(first, xyz(w)) <= 1e-9


def test_reset_takes_keywords_and_names_an_unknown_option(world: World) -> None:
    with pytest.raises(TypeError):
        world.reset(5)  # type: ignore[call-arg]
    with pytest.raises(WorldError, match="shuffle"):
        world.reset(options={"shuffle": True})
    with pytest.raises(WorldError, match="randomize"):
        world.reset(options={"randomize": "yes"})
    with pytest.raises(WorldError, match="shuffle"):
        World(options={"shuffle": True})
    assert world.reset(options={"randomize": False}).robot.location == "Front Door"


# --- independence ------------------------------------------------------------------------------


def test_two_worlds_in_one_process_do_not_interfere() -> None:
    with World() as a, World() as b:
        before_b, steps_b = xyz(b), b.steps
        actions: tuple[Action, ...] = (
            ("grab", "cube"),
            ("move_to", "Kitchen Shelf"),
            ("place", "Kitchen Shelf", "top"),
        )
        assert_all_succeeded(run_sequence(session_for(a), actions), actions)
        assert b.steps == steps_b
        assert xyz(b) == before_b
        assert b.robot_location() == "Front Door"
        assert b.holding is None
        # And the other way round.
        before_a, steps_a = xyz(a), a.steps
        assert session_for(b).call(move_to.TOOL, location="Living Room").status == "success"
        assert a.steps == steps_a
        assert xyz(a) == before_a


# --- construction ------------------------------------------------------------------------------


def test_gui_without_a_display_raises_world_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(WorldError, match="display"):
        World(gui=True)
