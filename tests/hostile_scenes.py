"""Hostile scene files: the shipped household with one thing made extreme (a location at x = 1e15, a
time step of 1e-9, a room of 1e300 m, 10,000 objects or walls, 300 more locations, a 1e9 m cube, a
robot or URDF path that leaves the scene's folder, a file of 3 MB). Each is refused at load in one
line naming what is wrong; the tests (tests/e2e/test_hostile_scenes.py) and the bench of refusal
times (tests/bench/bench_edges.py) write them with `write_all`."""

from __future__ import annotations

import copy
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

from robocog.assets import ASSETS_DIR

Scene = dict[str, Any]


def _household() -> Scene:
    data: Scene = yaml.safe_load((ASSETS_DIR / "scenes" / "household.yaml").read_text(encoding="utf-8"))
    return data


def _far_location(s: Scene) -> None:
    s["locations"][1]["x"] = 1e15


def _tiny_time_step(s: Scene) -> None:
    s["physics"] = {**s.get("physics", {}), "time_step": 1e-9}


def _huge_room(s: Scene) -> None:
    s["rooms"][0]["x"] = [0.0, 1e300]


def _many_objects(s: Scene) -> None:
    cube = s["objects"][0]
    s["objects"] = [{**cube, "name": f"cube {i}", "start": {"pose": [0.0, 0.0, 0.1 + i * 1e-3]}} for i in range(10_000)]


def _many_walls(s: Scene) -> None:
    wall = s["walls"][0]
    s["walls"] = [copy.deepcopy(wall) for _ in range(10_000)]


def _many_locations(s: Scene) -> None:
    s["locations"] += [{"name": f"spot {i}", "x": 0.0, "y": 0.0} for i in range(300)]


def _huge_cube(s: Scene) -> None:
    s["objects"][0]["size"] = [1e9, 1e9, 1e9]


def _robot_escapes(s: Scene) -> None:
    s["robot"] = "../../../../etc/passwd"


def _urdf_escapes(s: Scene) -> None:
    s["objects"][0].update(shape="urdf", urdf="../../../../../../../../etc/passwd")


def _huge_mass(s: Scene) -> None:
    s["objects"][0]["mass"] = 1e30


#: name -> (what it changes, the words the one-line refusal must carry)
HOSTILE: dict[str, tuple[Callable[[Scene], None], str]] = {
    "far_location": (_far_location, "locations[1].x"),
    "tiny_time_step": (_tiny_time_step, "physics.time_step"),
    "huge_room": (_huge_room, "rooms[0].x"),
    "many_objects": (_many_objects, "bytes, more than the 262,144 such a file may have"),
    "many_walls": (_many_walls, "bytes, more than the 262,144 such a file may have"),
    "many_locations": (_many_locations, "locations: List should have at most 200 items"),
    "huge_cube": (_huge_cube, "objects[0].size"),
    "huge_mass": (_huge_mass, "objects[0].mass"),
    "robot_escapes": (_robot_escapes, "robot: '../../../../etc/passwd' lies outside"),
    "urdf_escapes": (_urdf_escapes, "objects[0].urdf"),
}


def write_far_corridor(path: Path) -> Path:
    """A scene within every bound whose drives are long: the household at a 1 ms time step, with a
    corridor of locations out to (90, 90) (Front Door -> Far A (0, -90) -> Far B (90, -90) -> Far C
    (90, 90)). Driving to Far A takes 30,000 simulated steps, to Far B 60,000, to Far C 120,000: more
    than one action may take."""
    scene = _household()
    scene["physics"] = {**scene.get("physics", {}), "time_step": 0.001}
    scene["locations"] += [
        {"name": "Far A", "x": 0.0, "y": -90.0},
        {"name": "Far B", "x": 90.0, "y": -90.0},
        {"name": "Far C", "x": 90.0, "y": 90.0},
    ]
    scene["edges"] += [["Front Door", "Far A"], ["Far A", "Far B"], ["Far B", "Far C"]]
    scene["rooms"] = []  # the corridor lies in no room
    path.write_text(yaml.safe_dump(scene, sort_keys=False), encoding="utf-8")
    return path


def write_all(folder: Path) -> dict[str, tuple[Path, str]]:
    """Write every hostile scene into `folder` (and a 3 MB file, and a robot linked to /etc/passwd):
    name -> (file, the words its refusal must carry)."""
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, tuple[Path, str]] = {}
    for name, (change, words) in HOSTILE.items():
        scene = _household()
        change(scene)
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(scene, sort_keys=False), encoding="utf-8")
        out[name] = (path, words)
    big = folder / "huge_file.yaml"
    big.write_text(yaml.safe_dump(_household(), sort_keys=False) + ("# padding\n" * 330_000), encoding="utf-8")  # 3 MB
    out["huge_file"] = (big, "more than the")
    link = folder / "robot-link.yaml"
    if not link.exists():
        os.symlink("/etc/passwd", link)
    linked = _household()
    linked["robot"] = str(link)
    path = folder / "robot_link.yaml"
    path.write_text(yaml.safe_dump(linked, sort_keys=False), encoding="utf-8")
    out["robot_link"] = (path, "lies outside")
    return out
