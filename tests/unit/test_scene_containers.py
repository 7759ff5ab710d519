"""Containers in the scene schema and the layout check: kitchen_plus's drawer, cabinet and fridge as
data, their geometry from dimensions, malformed containers named by field, and a container that could
not stand or open where it is put named by the layout check."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from robocog.shared.containers import geometry
from robocog.shared.errors import ConfigError
from robocog.shared.scene import Scene
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.scene_layout import layout_problems


@pytest.fixture(scope="module")
def kitchen() -> dict[str, Any]:
    data = yaml.safe_load(scene_path("kitchen_plus").read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def changed(data: dict[str, Any], **container: Any) -> Scene:
    """kitchen_plus with its first container (the drawer unit) changed, validated."""
    out = copy.deepcopy(data)
    out["containers"][0].update(container)
    return Scene.model_validate(out)


def error_of(tmp_path: Path, data: dict[str, Any]) -> str:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_scene(path)
    return str(info.value)


def test_kitchen_plus_has_a_drawer_a_cabinet_and_a_fridge() -> None:
    scene = load_scene(scene_path("kitchen_plus"))
    assert [(c.name, c.kind) for c in scene.containers] == [
        ("kitchen_drawer", "drawer"),
        ("kitchen_cabinet", "cabinet"),
        ("fridge", "fridge"),
    ]
    assert {p.support for p in scene.place_positions} >= {"kitchen_drawer", "kitchen_cabinet", "fridge"}
    assert layout_problems(scene) == []


def test_the_geometry_follows_from_the_dimensions() -> None:
    scene = load_scene(scene_path("kitchen_plus"))
    drawer, cabinet, fridge = (geometry(c) for c in scene.containers)
    assert (drawer.joint, drawer.axis, drawer.open_q) == ("prismatic", (0.0, -1.0, 0.0), pytest.approx(0.36))
    assert drawer.interior_moves and not cabinet.interior_moves
    assert (cabinet.joint, fridge.joint) == ("revolute", "revolute")
    assert cabinet.open_q == pytest.approx(math.pi / 2)
    # Hinged on opposite sides (left and right as seen from the front), so their axes turn opposite ways.
    assert cabinet.axis[2] == -fridge.axis[2]
    # The interior lies within the carcass, its floor above the carcass's bottom.
    x0, y0, x1, y1 = fridge.footprint()
    ix0, iy0, ix1, iy1 = fridge.interior_rect()
    assert x0 < ix0 < ix1 < x1 and y0 < iy0 < iy1 < y1
    assert fridge.floor_z == pytest.approx(0.02)
    # What a drawer sweeps lies in front of it (it faces -y): its travel and a little more.
    _, sy0, _, sy1 = drawer.swept()
    assert sy1 == pytest.approx(y0_of(drawer)) and sy1 - sy0 == pytest.approx(0.39)


def y0_of(g: Any) -> float:
    return float(g.footprint()[1])


def test_a_malformed_container_is_a_scene_error_naming_the_field(tmp_path: Path, kitchen: dict[str, Any]) -> None:
    bad = copy.deepcopy(kitchen)
    bad["containers"][1]["kind"] = "wardrobe"
    assert "containers[1].kind: Input should be" in error_of(tmp_path, bad)
    bad = copy.deepcopy(kitchen)
    bad["containers"][0]["location"] = "Pantry"
    assert "containers[0] (kitchen_drawer): location 'Pantry' is not a location" in error_of(tmp_path, bad)
    bad = copy.deepcopy(kitchen)
    bad["containers"][2]["name"] = "kitchen_shelf"
    assert "duplicate names ['kitchen_shelf']" in error_of(tmp_path, bad)
    bad = copy.deepcopy(kitchen)
    bad["containers"][0]["size"] = [0.06, 0.45, 0.35]
    assert "four wall thicknesses" in error_of(tmp_path, bad)
    bad = copy.deepcopy(kitchen)
    bad["containers"][0]["travel"] = 0.45
    assert "containers[0].travel: a drawer slides out by less than its depth" in error_of(tmp_path, bad)
    bad = copy.deepcopy(kitchen)
    bad["place_positions"][-1]["support"] = "freezer"
    assert "support 'freezer' is neither 'floor', a furniture part nor a container" in error_of(tmp_path, bad)


def test_the_layout_check_sees_a_container_that_cannot_stand_or_open(kitchen: dict[str, Any]) -> None:
    into_wall = changed(kitchen, center=[2.2, 5.9, 0.175])
    assert "container kitchen_drawer: it overlaps walls[" in "\n".join(layout_problems(into_wall))
    # Turned to face the shelf (+x would face the cabinet): its drawer would slide into the cabinet.
    facing_cabinet = changed(kitchen, center=[3.05, 5.7, 0.175], size=[0.45, 0.45, 0.35], facing="+x")
    problems = "\n".join(layout_problems(facing_cabinet))
    assert "container kitchen_drawer: the sweep of it overlaps container kitchen_cabinet" in problems
    far = copy.deepcopy(kitchen)
    far["locations"] = [{**loc, "y": 3.9} if loc["name"] == "Kitchen Drawer" else loc for loc in far["locations"]]
    problems = "\n".join(layout_problems(Scene.model_validate(far)))
    assert "container kitchen_drawer: its interior is" in problems and "past the arm's reach" in problems
    outside = copy.deepcopy(kitchen)
    outside["place_positions"][-3]["center"] = [2.2, 5.3]
    problems = "\n".join(layout_problems(Scene.model_validate(outside)))
    assert "Kitchen Drawer / inside: its region is not inside kitchen_drawer" in problems
