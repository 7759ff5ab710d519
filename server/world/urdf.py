"""The arm's URDF as the world loads it: a copy derived at run time from the robot description.

- The joints named in `continuous_joints` lose their rotation limits (made continuous, as in the
  paper), and mesh paths are made absolute.
- The STL collision meshes are reduced to their extreme points (`arm_meshes`): the arm collides with
  nothing, and the reduced meshes give it the same bounding boxes.
- The OBJ visual meshes are simplified to a tenth of their triangles (`arm_visuals`), for the camera.

The copy is derived once per process and arm (every reset loads the arm) and written to the
temporary directory under a name that carries its digest, again if it has gone from there.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from functools import cache
from pathlib import Path

from robocog.server.world import arm_meshes, arm_visuals
from robocog.server.world.derived import derived_path, write_once
from robocog.shared.robot_spec import RobotSpec, resolve_urdf, revolute_joint_pattern


def derived_urdf(spec: RobotSpec) -> Path:
    """The arm's URDF with `continuous_joints` unlimited, absolute mesh paths, reduced collision
    meshes and simplified visual ones (derived once per process and arm; written again, with its
    meshes, if any of those files has gone: a temporary directory may be cleaned while a server runs)."""
    key = (spec.arm.urdf, tuple(spec.arm.continuous_joints))
    text, target = _derived(*key)
    if not all(path.exists() for path in _written(text, target)):
        _derived.cache_clear()  # derive again: the meshes that have gone are written again on the way
        text, target = _derived(*key)
        write_once(target, text.encode())
    return target


@cache
def _written(text: str, target: Path) -> tuple[Path, ...]:
    """The derived URDF and the derived meshes it names."""
    meshes = (Path(name) for name in re.findall(r'filename="([^"]+)"', text))
    return (target, *(mesh for mesh in meshes if mesh.parent == target.parent))


@cache
def _derived(urdf: str, continuous_joints: tuple[str, ...]) -> tuple[str, Path]:
    """The derived URDF's text and where it is written (written here once)."""
    source = resolve_urdf(urdf)
    text = source.read_text(encoding="utf-8")
    text = re.sub(r'filename="(?!/)([^"]+)"', lambda m: f'filename="{(source.parent / m.group(1)).as_posix()}"', text)
    text = re.sub(r"<collision>.*?</collision>", _reduced_collision, text, flags=re.S)
    text = re.sub(r"<visual>.*?</visual>", _simplified_visual, text, flags=re.S)
    for joint in continuous_joints:
        text, count = re.subn(revolute_joint_pattern(joint), r'\1"continuous"', text)
        if count != 1:
            raise ValueError(f"{source}: no revolute joint named {joint!r} to make continuous")
        block = re.compile(rf'(<joint\s+name="{re.escape(joint)}".*?</joint>)', re.S)
        text = block.sub(lambda m: re.sub(r'\s(lower|upper)="[^"]*"', "", m.group(1)), text)
    return text, write_once(derived_path(source.stem, text.encode(), ".urdf"), text.encode())


def _simplified_visual(block: re.Match[str]) -> str:
    return _meshes_replaced(block, arm_visuals.simplified_obj)


def _reduced_collision(block: re.Match[str]) -> str:
    return _meshes_replaced(block, arm_meshes.reduced_stl)


def _meshes_replaced(block: re.Match[str], derive: Callable[[Path], Path]) -> str:
    """The URDF block with each mesh file it names replaced by the one `derive` makes of it."""
    return re.sub(r'filename="([^"]+)"', lambda m: f'filename="{derive(Path(m.group(1))).as_posix()}"', block.group(0))
