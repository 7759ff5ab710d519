"""What the robot sees: look_around and the environment description (robocog://world/description).

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

from robocog.server.robots.session import RobotSession
from robocog.server.tools import grab, look_around
from robocog.server.world.describe import describe
from robocog.server.world.world import World
from tests.helpers import PAPER_LOCATIONS, PAPER_POSITIONS, T1_SEQUENCE
from tests.unit.world_helpers import expected_neighbours, run_sequence, xyz

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
