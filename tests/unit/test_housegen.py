"""The house generator (`robocog.agent.housegen`): one seed, one file byte for byte; the fifty shipped
houses are what their seeds generate, load by name, pass the layout check, and between them use the
whole furniture catalogue and at least ten kinds of objects; `robocog scene generate | list`."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import yaml

from robocog.agent.cli.main import main as robocog
from robocog.agent.housegen import SHIPPED_HOUSES, generate_house, house_name, house_yaml
from robocog.agent.housegen.catalogue import FURNITURE, OBJECTS
from robocog.shared.errors import ConfigError
from robocog.shared.scene import Scene
from robocog.shared.scene_files import GENERATED_DIR, generated_scene_names, load_scene, scene_names, scene_path
from robocog.shared.scene_layout import layout_problems

HOUSES = [house_name(seed) for seed in range(SHIPPED_HOUSES)]


@pytest.fixture(scope="module")
def houses() -> dict[str, Scene]:
    return {name: load_scene(scene_path(name)) for name in HOUSES}


def test_the_shipped_houses_are_what_their_seeds_generate_byte_for_byte() -> None:
    assert generated_scene_names() == HOUSES
    for seed, name in enumerate(HOUSES):
        assert (GENERATED_DIR / f"{name}.yaml").read_bytes() == house_yaml(seed).encode("utf-8"), (
            f"{name} differs from its seed's house: run `robocog scene generate --seed {seed} -o "
            f"assets/scenes/generated/{name}.yaml`"
        )


def test_a_seed_gives_the_same_bytes_and_another_seed_another_house() -> None:
    assert house_yaml(1234) == house_yaml(1234)
    assert house_yaml(1234) != house_yaml(1235)
    assert generate_house(1234, "mine")["name"] == "mine"
    assert yaml.safe_load(house_yaml(1234, "my: house"))["name"] == "my: house"


@pytest.mark.parametrize("name", HOUSES)
def test_every_shipped_house_loads_by_name_and_its_layout_is_sound(houses: dict[str, Scene], name: str) -> None:
    scene = houses[name]
    assert scene.name == name
    assert layout_problems(scene) == []
    assert 2 <= len(scene.rooms) <= 5
    doors = [loc.name for loc in scene.locations if loc.name.endswith(" Door")]
    assert len(doors) >= len(scene.rooms) - 1
    assert scene.robot_start in {room.name for room in scene.rooms}
    assert 6 <= len(scene.objects) <= 9
    for obj in scene.objects:
        assert obj.graspable and len(obj.descriptions) >= 3, obj
        assert scene.described_as(obj.descriptions[0]) == [obj.name]
    # Every location has a place position or is a doorway; every furniture location is the robot's way in.
    used = {p.location for p in scene.place_positions}
    assert {loc.name for loc in scene.locations} == used | set(doors)


def test_the_houses_use_the_whole_catalogue_and_ten_kinds_of_objects(houses: dict[str, Scene]) -> None:
    kinds = Counter(o.name for scene in houses.values() for o in scene.objects)
    assert set(kinds) == {k.name for k in OBJECTS} and len(kinds) >= 10
    assert {o.urdf for scene in houses.values() for o in scene.objects if o.urdf} == {k.urdf for k in OBJECTS if k.urdf}
    pieces = {f.name.rsplit("_", 1)[-1] for scene in houses.values() for f in scene.furniture}
    pieces |= {c.kind for scene in houses.values() for c in scene.containers}
    assert pieces == set(FURNITURE)
    assert {len(scene.rooms) for scene in houses.values()} == {2, 3, 4, 5}
    inside = [o for scene in houses.values() for o in scene.objects if o.start.position == "inside"]
    assert len(inside) >= 10  # some objects start shut in a drawer, a cabinet or a fridge


def test_the_generated_houses_are_named_like_scenes_but_listed_apart() -> None:
    assert scene_names() == ["flat", "household", "kitchen_plus", "suite_house"]
    assert scene_path("house-007") == GENERATED_DIR / "house-007.yaml"
    with pytest.raises(ConfigError, match=r"the generated houses house-000 \.\.\. house-049"):
        scene_path("house-050")


def test_scene_generate_writes_the_file_its_seed_makes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "h.yaml"
    assert robocog(["scene", "generate", "--seed", "7", "--out", str(out)]) == 0
    assert out.read_bytes() == (GENERATED_DIR / "house-007.yaml").read_bytes()
    assert "house 7 ->" in capsys.readouterr().err
    assert robocog(["scene", "generate", "--seed", "7"]) == 0
    assert capsys.readouterr().out == house_yaml(7)


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (["--seed", "-3"], "robocog: --seed: must be between 0 and 2147483647, not -3\n"),
        (["--seed", "1", "--name", " "], "robocog: --name: must not be empty\n"),
        (["--seed", "1", "--out", "/nonexistent/dir/h.yaml"], "robocog: --out: cannot write /nonexistent/dir/h.yaml"),
    ],
)
def test_scene_generate_refuses_bad_input_in_one_line(
    argv: list[str], error: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert robocog(["scene", "generate", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith(error) and err.count("\n") == 1


def test_scene_list_names_every_scene(capsys: pytest.CaptureFixture[str]) -> None:
    assert robocog(["scene", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["scene", "rooms", "locations", "positions", "objects"]
    assert [line.split()[0] for line in lines[1:]] == [*scene_names(), *HOUSES]
