"""The arm's URDF as the world loads it: a copy derived at run time from the robot description.

- The joints named in `continuous_joints` lose their rotation limits (made continuous, as in the
  paper), and mesh paths are made absolute.
- Every collision mesh becomes the box that bounds it. The robot's bodies collide with nothing
  (`Robot` masks them out of every contact), so their collision shapes only ever answer bounding-box
  questions (`getAABB`: the camera's test of whether the arm can be in a frame, the broadphase's
  overlap queries), and a box bounding the mesh gives the same link-frame bounds. Building PyBullet's
  shapes from the iiwa's STL meshes was 20 of the 27 ms `loadURDF` took, paid on every reset; the
  inertia comes from the file, so the arm's dynamics do not change.

The copy is written once per content (its name carries a digest) to the temporary directory.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import struct
import tempfile
import threading
from functools import cache
from pathlib import Path

import numpy as np

from robocog.shared.robot_spec import RobotSpec, resolve_urdf, revolute_joint_pattern

_COLLISION = re.compile(r"<collision\b[^>]*>.*?</collision>", re.S)
_MESH = re.compile(r'<mesh\s+filename="([^"]+)"(?:\s+scale="([^"]+)")?\s*/>')
_ORIGIN = re.compile(r"<origin\b[^>]*/>")
_ATTRIBUTE = r'\b{}="([^"]*)"'


def derived_urdf(spec: RobotSpec) -> Path:
    """The arm's URDF with `continuous_joints` unlimited, absolute mesh paths and box collisions
    (derived once per process and arm, written again if the file has gone)."""
    text, target = _derived(spec.arm.urdf, tuple(spec.arm.continuous_joints))
    if not target.exists():
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(target)  # atomic: parallel workers never see a half-written file
    return target


@cache
def _derived(urdf: str, continuous_joints: tuple[str, ...]) -> tuple[str, Path]:
    """The derived URDF's text and where it is written."""
    source = resolve_urdf(urdf)
    text = source.read_text(encoding="utf-8")
    text = re.sub(r'filename="(?!/)([^"]+)"', lambda m: f'filename="{(source.parent / m.group(1)).as_posix()}"', text)
    for joint in continuous_joints:
        text, count = re.subn(revolute_joint_pattern(joint), r'\1"continuous"', text)
        if count != 1:
            raise ValueError(f"{source}: no revolute joint named {joint!r} to make continuous")
        block = re.compile(rf'(<joint\s+name="{re.escape(joint)}".*?</joint>)', re.S)
        text = block.sub(lambda m: re.sub(r'\s(lower|upper)="[^"]*"', "", m.group(1)), text)
    text = _COLLISION.sub(lambda m: boxed_collision(m.group(0)), text)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    return text, Path(tempfile.gettempdir()) / "robocog-urdf" / f"{source.stem}-{digest}.urdf"


def boxed_collision(block: str) -> str:
    """A `<collision>` element with its mesh replaced by the box bounding the mesh's vertices (scaled,
    in the element's frame: the origin moves to the box's centre). Left as it is when the geometry is
    not a mesh, or a mesh of a format read here (STL, binary or text; OBJ)."""
    mesh = _MESH.search(block)
    if mesh is None:
        return block
    bounds = mesh_bounds(mesh.group(1))
    if bounds is None:
        return block
    scale = np.array([float(v) for v in mesh.group(2).split()]) if mesh.group(2) else np.ones(3)
    low, high = np.sort(np.stack([bounds[0] * scale, bounds[1] * scale]), axis=0)
    size, centre = high - low, (low + high) / 2
    origin = _ORIGIN.search(block)
    xyz, rpy = np.zeros(3), np.zeros(3)
    if origin is not None:
        xyz = _vector(origin.group(0), "xyz")
        rpy = _vector(origin.group(0), "rpy")
    moved = xyz + _rotation(rpy) @ centre
    new_origin = f'<origin rpy="{_floats(rpy)}" xyz="{_floats(moved)}"/>'
    box = f'<box size="{_floats(size)}"/>'
    block = _MESH.sub(box, block, count=1)
    if origin is None:
        return block.replace("<geometry>", f"{new_origin}\n      <geometry>", 1)
    return _ORIGIN.sub(new_origin, block, count=1)


@cache
def mesh_bounds(path: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The lowest and highest corner of a mesh file's vertices, or None (unknown format, unreadable)."""
    try:
        data = Path(path).read_bytes()
    except OSError:
        return None
    suffix = Path(path).suffix.lower()
    if suffix == ".stl":
        vertices = _stl_vertices(data)
    elif suffix == ".obj":
        lines = data.decode("utf-8", "replace").splitlines()
        vertices = np.array([[float(v) for v in line.split()[1:4]] for line in lines if line.startswith("v ")])
    else:
        return None
    if vertices.size == 0:
        return None
    return vertices.min(axis=0), vertices.max(axis=0)


def _stl_vertices(data: bytes) -> np.ndarray:
    """An STL file's vertices: binary (80-byte header, a count, 50 bytes per triangle) or text."""
    if len(data) >= 84:
        (count,) = struct.unpack_from("<I", data, 80)
        if 84 + 50 * count == len(data):
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attribute", "<u2")])
            triangles = np.frombuffer(data, dtype=record, count=count, offset=84)
            return triangles["v"].reshape(-1, 3).astype(np.float64)
    text = data.decode("utf-8", "replace")
    found = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text)
    return np.array([[float(v) for v in triple] for triple in found])


def _vector(element: str, name: str) -> np.ndarray:
    found = re.search(_ATTRIBUTE.format(name), element)
    return np.array([float(v) for v in found.group(1).split()]) if found else np.zeros(3)


def _rotation(rpy: np.ndarray) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw as a rotation matrix (Rz @ Ry @ Rx)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _floats(values: np.ndarray) -> str:
    return " ".join(f"{v:.6g}" if math.isfinite(v) else "0" for v in values)
