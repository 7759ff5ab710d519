"""The arm's collision meshes, reduced to what the world reads of them: their bounding boxes.

The arm collides with nothing (`robot.Robot` sets its collision masks to zero), so its collision
shapes serve only for their bounding boxes: `getAABB` (the camera's test of whether the arm is in
the frame) and the broadphase (`getOverlappingObjects`, free floor for an object that slipped).
PyBullet makes a convex hull of an STL mesh's vertices and keeps every vertex it was given, and an
STL lists a vertex once for each triangle at it: the iiwa's eight meshes are 44,000 points, about
2 MB in every world of a fleet. The mesh derived here keeps only the points that lie furthest along
a set of directions (the three axes both ways among them), a few hundred per link. Bullet computes a
hull's bounding box from its points' extremes along the axes, and those points are kept, so every
bounding box is the same to the bit (`tests/unit/test_world_memory.py` checks it).
"""

from __future__ import annotations

import functools
import math
import struct
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robocog.server.world.derived import derived_path, write_once

#: How many directions (besides the six along the axes) a kept point must be the furthest along.
DIRECTIONS = 250

_TRIANGLE = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def reduced_stl(source: Path) -> Path:
    """A binary STL whose vertices are `source`'s extreme points (see the module), in the temporary
    directory, named by the source's content: computed and written once per machine (again if it has
    gone); `source` itself when it is not a binary STL."""
    target = _target(source)
    if target is None:
        return source
    if not target.exists():
        data = _binary_stl(source)
        assert data is not None  # `_target` read it as one
        write_once(target, stl_bytes(extreme_points(_stl_points(data))))
    return target


@functools.cache
def _target(source: Path) -> Path | None:
    """Where `source` reduced is written, named by its content and the method (None: not a binary STL).
    Once per process: every reset builds the arm."""
    data = _binary_stl(source)
    if data is None:
        return None
    return derived_path(source.stem, f"robocog extreme points 1, {DIRECTIONS}".encode() + data, ".stl")


def extreme_points(points: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """The distinct points of `points` that lie furthest along one of the directions (in their order)."""
    along = points @ _directions().T.astype(np.float32)  # points x directions
    chosen = np.unique(np.concatenate([along.argmax(axis=0), along.argmin(axis=0)]))
    distinct = np.unique(points[chosen], axis=0)
    return np.ascontiguousarray(distinct, dtype=np.float32)


def stl_bytes(points: npt.NDArray[np.float32]) -> bytes:
    """A binary STL of triangles made of `points`, three by three (the last repeated to fill one)."""
    padded = np.concatenate([points, np.repeat(points[-1:], -len(points) % 3, axis=0)])
    triangles = np.zeros(len(padded) // 3, dtype=_TRIANGLE)
    triangles["vertices"] = padded.reshape(-1, 3, 3)
    return (
        b"robocog: extreme points of an arm's collision mesh".ljust(80, b" ")
        + struct.pack("<I", len(triangles))
        + triangles.tobytes()
    )


def _binary_stl(source: Path) -> bytes | None:
    """The bytes of `source` if it is a binary STL of at least one triangle, else None."""
    if source.suffix.lower() != ".stl" or not source.is_file():
        return None
    data = source.read_bytes()
    if len(data) < 84:
        return None
    (count,) = struct.unpack_from("<I", data, 80)
    if count == 0 or len(data) != 84 + 50 * count:  # an ASCII STL, or not an STL
        return None
    return data


def _stl_points(data: bytes) -> npt.NDArray[np.float32]:
    """Every vertex of a binary STL's bytes (once per triangle at it)."""
    (count,) = struct.unpack_from("<I", data, 80)
    triangles = np.frombuffer(data, dtype=_TRIANGLE, count=count, offset=84)
    return np.ascontiguousarray(triangles["vertices"].reshape(-1, 3))


@functools.cache
def _directions() -> npt.NDArray[np.float64]:
    """The six axis directions, then `DIRECTIONS` spread evenly over the sphere (a Fibonacci lattice)."""
    axes = np.vstack([np.eye(3), -np.eye(3)])
    i = np.arange(DIRECTIONS) + 0.5
    z = 1 - 2 * i / DIRECTIONS
    r = np.sqrt(1 - z * z)
    phi = i * math.pi * (3 - math.sqrt(5))
    return np.vstack([axes, np.column_stack([r * np.cos(phi), r * np.sin(phi), z])])
