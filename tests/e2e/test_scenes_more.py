"""More of the world: the suite's scenes (suite_house, the paper's layout with more objects and a
sideboard; flat, a different house), their objects' referring expressions, the layout check every
shipped scene passes, and scene names (`scene_path`).

Real PyBullet throughout: one world per scene for the module, reset before each test. Every graspable
object is carried from its start over every free place position of its scene with the world's own
actions, and ground truth (the physics state) must report it resting on each.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import grab
from robocog.server.world.world import DEFAULT_SCENE, World
from robocog.shared.errors import ConfigError
from robocog.shared.scene import Location, PlacePosition, Scene
from robocog.shared.scene_files import SCENES_DIR, load_scene, scene_names, scene_path
from robocog.shared.scene_layout import layout_problems
from tests.helpers import PAPER_EDGES, PAPER_LOCATIONS, PAPER_POSITIONS

NEW_SCENES = ("suite_house", "flat")
#: The graspable objects of each new scene (the scene files are the data; this is the expectation).
GRASPABLE = {
    "suite_house": ("cube", "box", "mug", "bottle", "book", "duck"),
    "flat": ("parcel", "book", "bottle", "mug", "duck"),
}
CARRIES = [(scene, obj) for scene in NEW_SCENES for obj in GRASPABLE[scene]]


@pytest.fixture(scope="module")
def worlds() -> Iterator[dict[str, World]]:
    built = {name: World(name) for name in NEW_SCENES}
    yield built
    for world in built.values():
        world.close()


def fresh(worlds: dict[str, World], scene: str) -> World:
    world = worlds[scene]
    world.reset()
    return world


def drive_to(world: World, location: str) -> None:
    path = world.map.shortest_path(world.robot_location(), location)
    assert path is not None, f"no path to {location}"
    world.drive(path)
    assert world.robot_location() == location


def scene_data(name: str) -> dict[str, Any]:
    data = yaml.safe_load((SCENES_DIR / f"{name}.yaml").read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def write_scene(tmp_path: Path, data: dict[str, Any]) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


# --- the scenes load, validate and lay out soundly ------------------------------------------------


@pytest.mark.parametrize("name", ["household", *NEW_SCENES, "kitchen_plus"])
def test_shipped_scene_loads_and_its_layout_is_sound(name: str) -> None:
    scene = load_scene(scene_path(name))
    assert scene.name == name
    assert layout_problems(scene) == []


def test_the_shipped_scenes_are_the_four() -> None:
    assert scene_names() == ["flat", "household", "kitchen_plus", "suite_house"]


def test_household_is_the_papers_world_unchanged() -> None:
    scene = load_scene(DEFAULT_SCENE)
    assert {loc.name: (loc.x, loc.y) for loc in scene.locations} == PAPER_LOCATIONS
    assert {frozenset(e) for e in scene.edges} == {frozenset(e) for e in PAPER_EDGES}
    assert {(p.location, p.name) for p in scene.place_positions} == {
        (loc, pos) for loc, positions in PAPER_POSITIONS.items() for pos in positions
    }
    assert {o.name: (o.start.location, o.start.position, o.graspable) for o in scene.objects} == {
        "cube": ("Front Door", "floor", True),
        "box": ("Living Room", "floor", True),
        "mug": ("Kitchen Table", "middle", True),
        "tv": (None, None, False),
    }
    assert [f.name for f in scene.furniture] == ["kitchen_shelf", "kitchen_table", "tv_table"]
    assert all(not o.descriptions for o in scene.objects)


def test_suite_house_is_the_papers_layout_plus_a_sideboard_and_three_objects() -> None:
    paper, suite = load_scene(DEFAULT_SCENE), load_scene(scene_path("suite_house"))
    assert set(paper.locations) <= set(suite.locations)
    assert set(paper.edges) <= set(suite.edges)
    assert set(paper.place_positions) <= set(suite.place_positions)
    assert paper.walls == suite.walls and paper.rooms == suite.rooms
    assert all(f in suite.furniture for f in paper.furniture)
    starts = {o.name: o.start for o in suite.objects}
    assert {o.name: o.start for o in paper.objects} == {n: starts[n] for n in ("cube", "box", "mug", "tv")}
    added = [f.name for f in suite.furniture if f not in paper.furniture]
    assert added == ["sideboard"]
    sideboard = [(p.location, p.name) for p in suite.place_positions if p.support.startswith("sideboard/")]
    assert sideboard == [("Living Room Sideboard", "left"), ("Living Room Sideboard", "right")]
    assert ("Living Room", "Living Room Sideboard") in suite.edges
    room = next(r for r in suite.rooms if r.name == "Living Room")
    where = suite.location("Living Room Sideboard")
    assert room.x[0] <= where.x <= room.x[1] and room.y[0] <= where.y <= room.y[1]
    extra = {o.name: o for o in suite.objects if o.name not in {p.name for p in paper.objects}}
    assert sorted(extra) == ["book", "bottle", "duck"]
    assert {n: o.urdf or o.shape for n, o in extra.items()} == {
        "bottle": "cylinder",
        "book": "box",
        "duck": "duck_vhacd.urdf",
    }


def test_flat_is_a_different_house() -> None:
    paper, flat = load_scene(DEFAULT_SCENE), load_scene(scene_path("flat"))
    assert not {loc.name for loc in paper.locations} & {loc.name for loc in flat.locations} - {"Living Room"}
    assert len(flat.rooms) == 4 and flat.robot_start == "Entrance"
    graspable = [o.name for o in flat.objects if o.graspable]
    assert len(graspable) >= 4 and tuple(graspable) == GRASPABLE["flat"]
    heavy = [o for o in flat.objects if not o.graspable]
    assert [o.name for o in heavy] == ["tv"] and heavy[0].mass >= 10
    supports = {p.support.split("/")[0] for p in flat.place_positions if p.support != "floor"}
    assert supports == {"bookcase", "kitchen_counter", "dining_table", "nightstand"}


# --- physics: every object to every free position ------------------------------------------------


@pytest.mark.parametrize(("scene", "obj"), CARRIES)
def test_object_goes_from_its_start_to_every_free_position(worlds: dict[str, World], scene: str, obj: str) -> None:
    world = fresh(worlds, scene)
    start = world.placement(obj)
    assert start.state == "on_position", start
    others = {name: (p.location, p.position) for name, p in world.placements().items() if name != obj}
    home = (str(start.location), str(start.position))
    free = [key for key in world.sim.positions if world.occupant(*key, ignore=obj) is None]
    assert home in free and len(free) >= 4
    drive_to(world, home[0])
    assert world.pick(obj).ok, f"{obj} cannot be picked from {start.location} / {start.position}"
    for location, position in [*(key for key in free if key != home), home]:  # back home last
        drive_to(world, location)
        reach = world.put_down(location, position)
        assert reach.ok, f"{obj} on {location} / {position}: {reach}"
        where = world.placement(obj)
        assert (where.state, where.location, where.position, where.resting) == (
            "on_position",
            location,
            position,
            True,
        )
        assert world.occupant(location, position) == obj
        taken = {(p.location, p.position): p.occupied_by for p in world.state().positions}
        assert taken[(location, position)] == obj
        picked = world.pick(obj)
        assert picked.ok, f"{obj} cannot be picked from {location} / {position}: {picked}"
        assert world.holding == obj
    # The other objects stayed where they were.
    assert {name: (p.location, p.position) for name, p in world.placements().items() if name != obj} == others


@pytest.mark.parametrize("scene", NEW_SCENES)
def test_randomized_starts_rest_every_graspable_object_on_its_own_position(
    worlds: dict[str, World], scene: str
) -> None:
    world = worlds[scene]
    for seed in (1, 2, 3):
        world.reset(seed=seed, options={"randomize": True})
        placed = world.placements()
        spots = [(placed[o].location, placed[o].position) for o in GRASPABLE[scene]]
        assert all(placed[o].state == "on_position" and placed[o].resting for o in GRASPABLE[scene]), placed
        assert len(set(spots)) == len(spots)


@pytest.mark.parametrize("scene", NEW_SCENES)
def test_the_heavy_object_refuses_a_grab(worlds: dict[str, World], scene: str) -> None:
    world = fresh(worlds, scene)
    before = world.placement("tv")
    drive_to(world, str(before.location))
    result = RobotSession(SessionConfig(), world=world).call(grab.TOOL, object="tv")
    assert (result.status, result.error) == ("failure", "not_graspable")
    assert world.holding is None
    after = world.placement("tv")
    assert after.location == before.location
    assert max(abs(a - b) for a, b in zip(after.xyz, before.xyz, strict=True)) < 1e-3


# --- referring expressions ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("scene", "text", "expected"),
    [
        ("suite_house", "the drinking vessel", ["mug"]),
        ("suite_house", "The  Heavy thing", ["tv"]),
        ("suite_house", "a rubber duck", ["duck"]),
        ("suite_house", "paperback", ["book"]),
        ("suite_house", "bottle", ["bottle"]),
        ("suite_house", "the banana", []),
        ("flat", "package", ["parcel"]),
        ("flat", "the heavy thing", ["tv"]),
    ],
)
def test_objects_are_found_by_their_descriptions(scene: str, text: str, expected: list[str]) -> None:
    assert load_scene(scene_path(scene)).described_as(text) == expected


@pytest.mark.parametrize("name", NEW_SCENES)
def test_every_object_of_a_new_scene_has_descriptions(name: str) -> None:
    assert all(len(o.descriptions) >= 2 for o in load_scene(scene_path(name)).objects)


@pytest.mark.parametrize(
    ("descriptions", "problem"),
    [
        (["cup", "  "], "objects[2].descriptions[1]: String should match pattern"),
        (["cup", "the"], "objects[2].descriptions[1]: 'the' says nothing once its article is dropped"),
        (["cup", "The Cup"], "objects[2].descriptions[1]: 'The Cup' is given twice"),
        (["the mug"], "objects[2].descriptions[0]: 'the mug' is the object's own name"),
        (["cup", "the cube"], "objects[2].descriptions[1] (mug): 'the cube' names the cube"),
        (["two\nlines"], "objects[2].descriptions[0]: String should match pattern"),
        ("cup", "objects[2].descriptions: Input should be a valid list"),
    ],
)
def test_bad_descriptions_are_scene_errors(tmp_path: Path, descriptions: Any, problem: str) -> None:
    data = scene_data("suite_house")
    assert data["objects"][2]["name"] == "mug"
    data["objects"][2]["descriptions"] = descriptions
    path = write_scene(tmp_path, data)
    with pytest.raises(ConfigError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: {problem}")


# --- the layout check catches what a world cannot use ---------------------------------------------


def broken(change: str) -> Scene:
    """suite_house with one layout defect (built without re-validation, as a programmatic scene is)."""
    scene = load_scene(scene_path("suite_house"))
    if change == "disconnected":
        return scene.model_copy(update={"locations": [*scene.locations, Location(name="Garage", x=1.0, y=-1.0)]})
    if change == "far":
        moved = [
            p.model_copy(update={"center": (5.5, -4.6)}) if (p.location, p.name) == ("Living Room", "floor") else p
            for p in scene.place_positions
        ]
        return scene.model_copy(update={"place_positions": moved})
    furniture = copy.deepcopy(list(scene.furniture))
    if change == "into_wall":
        side = furniture[-1]
        part = side.parts[0].model_copy(update={"center": (1.5, -5.85, 0.585)})
        furniture[-1] = side.model_copy(update={"parts": [part, *side.parts[1:]]})
        return scene.model_copy(update={"furniture": furniture})
    if change == "under_furniture":
        spot = PlacePosition(
            location="Living Room Sideboard", name="floor", center=(1.5, -5.5), size=(0.4, 0.4), support="floor"
        )
        return scene.model_copy(update={"place_positions": [*scene.place_positions, spot]})
    assert change == "overlapping"
    spot = PlacePosition(
        location="Living Room Sideboard", name="middle", center=(1.5, -5.6), size=(0.4, 0.35), support="sideboard/top"
    )
    return scene.model_copy(update={"place_positions": [*scene.place_positions, spot]})


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        ("disconnected", "locations ['Garage'] cannot be reached from 'Front Door' over the edges"),
        ("far", "place position Living Room / floor: 1.62 m from its location, past the arm's reach (0.7 m)"),
        ("into_wall", "furniture sideboard/top overlaps walls[10]"),
        ("under_furniture", "Living Room Sideboard / floor: the floor there is under furniture sideboard/top"),
        ("overlapping", "Living Room Sideboard / left overlaps Living Room Sideboard / middle on sideboard/top"),
    ],
)
def test_layout_problems_name_the_defect(change: str, problem: str) -> None:
    problems = layout_problems(broken(change))
    assert any(problem in line for line in problems), problems


# --- scene names ------------------------------------------------------------------------------------


def test_scene_path_resolves_names_and_keeps_paths(tmp_path: Path) -> None:
    assert scene_path("flat") == SCENES_DIR / "flat.yaml"
    assert scene_path("household") == DEFAULT_SCENE
    assert scene_path(Path("suite_house")) == SCENES_DIR / "suite_house.yaml"
    assert scene_path("elsewhere/flat.yaml") == Path("elsewhere/flat.yaml")
    assert scene_path(tmp_path / "mine.yaml") == tmp_path / "mine.yaml"
    own = tmp_path / "flat"  # an existing file is a path even without a suffix
    own.write_text("name: mine\n", encoding="utf-8")
    assert scene_path(str(own)) == own


def test_unknown_scene_name_lists_the_known_ones() -> None:
    with pytest.raises(ConfigError) as info:
        scene_path("castle")
    assert str(info.value) == (
        "scene 'castle': no such scene; known scenes: flat, household, kitchen_plus, suite_house, "
        "and the generated houses house-000 ... house-049 (or give the path of a scene YAML)"
    )
    with pytest.raises(ConfigError, match="known scenes: flat, household, kitchen_plus, suite_house"):
        World("castle")


def test_server_command_line_takes_a_scene_name(capsys: pytest.CaptureFixture[str]) -> None:
    from robocog.server.cli import main

    assert main(["--scene", "castle"]) == 2
    assert (
        "scene 'castle': no such scene; known scenes: flat, household, kitchen_plus, suite_house"
        in capsys.readouterr().err
    )
