"""Names a model gives: close names suggested, articles stripped, a location, an object or a piece of
furniture named where another kind was meant.

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.tools import grab, move_to, place
from robocog.server.world.navigation import closest, strip_articles
from robocog.server.world.world import World
from tests.helpers import PAPER_LOCATIONS

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
