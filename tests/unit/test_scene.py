"""The scene schema and loader: the shipped household, malformed files, and scenes extended as data."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pybullet_data
import pytest
import yaml

from robocog.assets import ASSETS_DIR
from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import grab, look_around, move_to
from robocog.server.world.world import DEFAULT_SCENE, World
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import load_config
from robocog.shared.robot_spec import load_robot
from robocog.shared.scene import Scene
from robocog.shared.scene_files import load_scene
from tests.helpers import PAPER_EDGES, PAPER_LOCATIONS, PAPER_POSITIONS


@pytest.fixture(scope="module")
def household() -> dict[str, Any]:
    data = yaml.safe_load(DEFAULT_SCENE.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def write_scene(tmp_path: Path, data: Any, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def scene_error(path: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_scene(path)
    return str(info.value)


# --- the shipped scene -------------------------------------------------------------------------


def test_household_scene_has_the_papers_locations_and_edges() -> None:
    scene = load_scene(DEFAULT_SCENE)
    assert {loc.name: (loc.x, loc.y) for loc in scene.locations} == PAPER_LOCATIONS
    assert {frozenset(e) for e in scene.edges} == {frozenset(e) for e in PAPER_EDGES}
    assert scene.robot_start == "Front Door"


def test_household_scene_has_the_papers_place_positions_and_objects() -> None:
    scene = load_scene(DEFAULT_SCENE)
    assert {(p.location, p.name) for p in scene.place_positions} == {
        (location, position) for location, positions in PAPER_POSITIONS.items() for position in positions
    }
    starts = {o.name: (o.start.location, o.start.position) for o in scene.objects}
    assert starts["cube"] == ("Front Door", "floor")
    assert starts["box"] == ("Living Room", "floor")
    assert starts["mug"] == ("Kitchen Table", "middle")
    tv = next(o for o in scene.objects if o.name == "tv")
    assert not tv.graspable
    assert tv.start.pose is not None


# --- malformed scenes --------------------------------------------------------------------------


def test_edge_to_unknown_location_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["edges"].append(["Front Door", "Attic"])
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert str(path) in message
    assert f"edges[{len(data['edges']) - 1}]" in message
    assert message == f"{path}: edges[{len(data['edges']) - 1}]: 'Attic' is not a location"


def test_missing_locations_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    del data["locations"]
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert str(path) in message
    assert "locations" in message
    assert "required" in message.lower()


def test_invalid_yaml_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("name: broken\nlocations: [{name: Front Door, x: 0, y: 0}\n  edges: ]\n", encoding="utf-8")
    message = scene_error(path)
    assert str(path) in message
    assert message == f"{path}: line 3, column 3: not valid YAML: expected ',' or ']', but got '<scalar>'"


def test_object_starting_on_a_missing_position_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    cube = next(o for o in data["objects"] if o["name"] == "cube")
    cube["start"] = {"location": "Front Door", "position": "shelf"}
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert str(path) in message
    assert "objects[0] (cube)" in message
    assert "Front Door / shelf" in message and "is not a place position" in message


def test_wrong_field_type_names_the_field(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["locations"][2]["x"] = "three"
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert str(path) in message
    assert "locations[2].x" in message
    assert "number" in message


def test_misspelt_field_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["objects"][0]["colour"] = data["objects"][0].pop("color")
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert "objects[0].colour" in message
    assert "Extra inputs are not permitted" in message


def test_unknown_robot_start_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["robot_start"] = "Garage"
    message = scene_error(write_scene(tmp_path, data))
    assert "robot_start: 'Garage' is not a location" in message


def test_place_position_on_unknown_support_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["place_positions"][0]["support"] = "kitchen_shelf/roof"
    message = scene_error(write_scene(tmp_path, data))
    assert "place_positions[0]" in message
    assert "kitchen_shelf/roof" in message


def test_duplicate_location_names_are_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["locations"].append({"name": "Front Door", "x": 9.0, "y": 9.0})
    message = scene_error(write_scene(tmp_path, data))
    assert "locations: duplicate names ['Front Door']" in message


def test_scene_that_is_not_a_mapping_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "list.yaml"
    path.write_text("- just\n- a list\n", encoding="utf-8")
    message = scene_error(path)
    assert str(path) in message


def test_missing_scene_file_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.yaml"
    message = scene_error(path)
    assert str(path) in message and "file not found" in message


def test_world_from_a_malformed_scene_path_raises_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["edges"].append(["Front Door", "Attic"])
    path = write_scene(tmp_path, data)
    with pytest.raises(ConfigError, match="Attic"):
        World(path)


# --- scenes extended as data -------------------------------------------------------------------


def extended_scene(household: dict[str, Any]) -> dict[str, Any]:
    """The household plus a coat rack in the hallway: one location, one edge, one position, one object."""
    data = copy.deepcopy(household)
    data["locations"].append({"name": "Coat Rack", "x": 1.5, "y": -1.5})
    data["edges"].append(["Coat Rack", "Front Door"])
    data["place_positions"].append(
        {"location": "Coat Rack", "name": "floor", "center": [1.5, -2.1], "size": [0.4, 0.4], "support": "floor"}
    )
    data["objects"].append(
        {
            "name": "ball",
            "shape": "cylinder",
            "size": [0.07, 0.07, 0.07],
            "mass": 0.1,
            "color": [0.9, 0.8, 0.1, 1.0],
            "start": {"location": "Coat Rack", "position": "floor"},
        }
    )
    return data


def test_extended_scene_loads(tmp_path: Path, household: dict[str, Any]) -> None:
    scene = load_scene(write_scene(tmp_path, extended_scene(household)))
    assert isinstance(scene, Scene)
    assert scene.location("Coat Rack").x == 1.5
    assert ("Coat Rack", "Front Door") in scene.edges
    assert [o.name for o in scene.objects][-1] == "ball"


def test_world_sees_an_object_added_to_the_scene(tmp_path: Path, household: dict[str, Any]) -> None:
    with World(write_scene(tmp_path, extended_scene(household))) as world:
        ball = world.placement("ball")
        assert (ball.state, ball.location, ball.position) == ("on_position", "Coat Rack", "floor")
        robot = RobotSession(SessionConfig(), world=world)
        views = {v.name: v for v in robot.call(look_around.TOOL).locations}
        assert views["Coat Rack"].objects == ["ball"]
        assert views["Coat Rack"].neighbours == ["Front Door"]
        assert "Coat Rack" in views["Front Door"].neighbours
        assert [(p.name, p.occupied_by) for p in views["Coat Rack"].place_positions] == [("floor", "ball")]
        # The original objects are where they were.
        assert world.placement("cube").position == "floor"


def test_robot_can_fetch_an_object_added_to_the_scene(tmp_path: Path, household: dict[str, Any]) -> None:
    with World(write_scene(tmp_path, extended_scene(household))) as world:
        robot = RobotSession(SessionConfig(), world=world)
        moved = robot.call(move_to.TOOL, location="coat rack")
        assert moved.status == "success", moved.message
        assert moved.path == ["Front Door", "Coat Rack"]
        grabbed = robot.call(grab.TOOL, object="ball")
        assert grabbed.status == "success", grabbed.message
        assert robot.call(move_to.TOOL, location="Front Door").status == "success"
        assert world.holding == "ball"


# --- every problem on one line: FILE: FIELD: problem -----------------------------------------------


def test_non_finite_numbers_are_scene_errors(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["locations"][0]["x"] = float("nan")
    path = write_scene(tmp_path, data)
    assert ".nan" in path.read_text(encoding="utf-8")
    assert scene_error(path) == f"{path}: locations[0].x: must be a finite number, not NaN or infinity"
    data = copy.deepcopy(household)
    data["furniture"][0]["parts"][0]["center"][2] = float("-inf")
    message = scene_error(write_scene(tmp_path, data))
    assert message.endswith(": furniture[0].parts[0].center[2]: must be a finite number, not NaN or infinity")


def test_nan_given_as_text_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["physics"]["gravity"] = "nan"
    path = write_scene(tmp_path, data)
    assert scene_error(path) == f"{path}: physics.gravity: Input should be a finite number"


def test_two_objects_on_one_start_position_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    names = [o["name"] for o in data["objects"]]
    data["objects"][names.index("box")]["start"] = {"location": "Front Door", "position": "floor"}
    path = write_scene(tmp_path, data)
    assert scene_error(path) == (
        f"{path}: objects[{names.index('box')}] (box): start position Front Door / floor is already taken by cube"
    )


def test_non_utf8_file_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "latin1.yaml"
    path.write_bytes("name: kitchen\nrobot_start: Caf\u00e9\n".encode("latin-1"))
    assert scene_error(path) == f"{path}: line 2: not UTF-8 text (byte 0xe9); save the file as UTF-8"


def test_empty_file_is_a_scene_error(tmp_path: Path) -> None:
    path = tmp_path / "empty.yaml"
    path.write_text("", encoding="utf-8")
    assert scene_error(path) == f"{path}: expected a mapping of fields (name: value), got an empty file"


def test_a_directory_is_a_scene_error(tmp_path: Path) -> None:
    assert scene_error(tmp_path) == f"{tmp_path}: is a directory, not a file"


def test_model_validator_errors_name_their_field(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["objects"][0]["urdf"] = "objects/mug.urdf"
    path = write_scene(tmp_path, data)
    assert scene_error(path) == (
        f"{path}: objects[0].urdf: shape 'urdf' needs a urdf path, and a urdf path needs shape 'urdf'"
    )
    data = copy.deepcopy(household)
    data["objects"][0]["start"] = {"location": "Front Door"}
    path = write_scene(tmp_path, data)
    assert scene_error(path) == f"{path}: objects[0].start: give either location and position, or pose"


def test_missing_robot_file_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    data["robot"] = "robot/nowhere.yaml"
    path = write_scene(tmp_path, data)
    assert scene_error(path) == (
        f"{path}: robot: 'robot/nowhere.yaml': no such file (robot files are relative to {ASSETS_DIR})"
    )


def write_robot(tmp_path: Path, household: dict[str, Any], **arm: Any) -> tuple[Path, Path]:
    """A scene whose robot is the shipped one with `arm` fields changed; returns (scene, robot) paths."""
    robot = yaml.safe_load((ASSETS_DIR / "robot" / "iiwa_mobile.yaml").read_text(encoding="utf-8"))
    robot["arm"].update(arm)
    robot_path = tmp_path / "robot.yaml"
    robot_path.write_text(yaml.safe_dump(robot), encoding="utf-8")
    data = copy.deepcopy(household)
    data["robot"] = str(robot_path)  # an absolute path: as given
    return write_scene(tmp_path, data), robot_path


def test_robot_with_a_missing_urdf_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    scene, robot = write_robot(tmp_path, household, urdf="kuka_iiwa/nowhere.urdf")
    assert scene_error(scene) == (
        f"{robot}: arm.urdf: 'kuka_iiwa/nowhere.urdf': no such file in pybullet_data ({pybullet_data.getDataPath()})"
    )
    with pytest.raises(ConfigError, match=r"arm\.urdf"):
        load_robot(robot)


def test_robot_that_does_not_fit_its_urdf_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    scene, robot = write_robot(tmp_path, household, continuous_joints=["elbow"])
    assert scene_error(scene) == f"{robot}: arm.continuous_joints: kuka_iiwa/model.urdf has no revolute joint 'elbow'"
    scene, robot = write_robot(tmp_path, household, rest_pose=[0.0, 1.0])
    assert scene_error(scene) == f"{robot}: arm.rest_pose: 2 joint angles, but kuka_iiwa/model.urdf has 7 joints"


def test_object_with_a_missing_urdf_is_a_scene_error(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    mug = next(i for i, o in enumerate(data["objects"]) if o["name"] == "mug")
    data["objects"][mug]["urdf"] = "objects/no_mug.urdf"
    path = write_scene(tmp_path, data)
    assert scene_error(path).startswith(f"{path}: objects[{mug}].urdf: 'objects/no_mug.urdf': no such file")


def test_many_problems_stay_on_one_line(tmp_path: Path, household: dict[str, Any]) -> None:
    data = copy.deepcopy(household)
    for loc in data["locations"]:
        loc["x"] = "far"
    path = write_scene(tmp_path, data)
    message = scene_error(path)
    assert "\n" not in message
    assert message.startswith(f"{path}: locations[0].x: Input should be a valid number")
    assert message.endswith(f"; and {len(data['locations']) - 3} more")


def test_study_config_errors_are_one_line_with_the_field(tmp_path: Path) -> None:
    path = tmp_path / "study.yaml"
    path.write_text("models: [{model: scripted/planner, params: {temperature: .inf}}]\n", encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value) == f"{path}: models[0].params.temperature: must be a finite number, not NaN or infinity"
    path.write_text("models: [{model: a, label: x}, {model: b, label: x}]\n", encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value).startswith(f"{path}: models: two models share a name")
