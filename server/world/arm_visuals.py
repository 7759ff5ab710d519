"""The arm's visual meshes, simplified for the camera: a tenth of their triangles.

Every world of a fleet holds its own copy of the arm's visual meshes, expanded for TinyRenderer
(three vertices of its own for every triangle, with a normal each): the iiwa's eight OBJ meshes are
14,758 triangles, 3.8 MB in every world. The camera draws 240 x 180 pixels, in which the arm, when it
is in the frame at all, covers a few thousand of them; a tenth of the triangles, chosen by quadric
error (`fast_simplification`), keeps its outline and shading. Each simplified mesh is written once
to the temporary directory, named by its source's content, with the source's materials beside it.
"""

from __future__ import annotations

import functools
import re
from importlib.metadata import version
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robocog.server.world.derived import derived_path, write_once

#: The share of a visual mesh's triangles the simplification removes.
REDUCTION = 0.9
#: Meshes with fewer triangles than this are kept as they are.
SMALL = 200


def simplified_obj(source: Path) -> Path:
    """`source` (an OBJ mesh) with a tenth of its triangles, in the temporary directory (written
    there once, and again if it has gone); `source` itself when it is not an OBJ file, has fewer than
    `SMALL` faces or uses more than one material."""
    target = _target(source) if source.suffix.lower() == ".obj" and source.is_file() else None
    if target is None:
        return source
    if not target.exists():
        _write(source, target)
    return target


@functools.cache
def _target(source: Path) -> Path | None:
    """Where `source` simplified is written, named by its content and the method (None: kept as is)."""
    data = b"\n" + source.read_bytes()
    if data.count(b"\nf ") < SMALL or data.count(b"\nusemtl ") > 1:
        return None
    method = f"robocog arm visuals 1, {REDUCTION}, fast-simplification {_simplifier_version()}"
    return derived_path(source.stem, method.encode() + data[1:], ".obj")


@functools.cache
def _simplifier_version() -> str:
    return version("fast-simplification")


def _write(source: Path, target: Path) -> None:
    import fast_simplification  # only where a mesh is simplified: once per machine and mesh

    text = source.read_text(encoding="utf-8", errors="replace")
    points, faces = fast_simplification.simplify(*parse_obj(text), target_reduction=REDUCTION)
    write_once(target, obj_bytes(points, faces, _materials(source, text, target.with_suffix(".mtl"))))


def parse_obj(text: str) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
    """An OBJ's vertices and its faces as triangles (a polygon as a fan), texture and normals dropped."""
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    for line in text.splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            vertices.append([float(x) for x in fields[1:4]])
        elif fields[0] == "f":
            corners = [int(f.split("/")[0]) for f in fields[1:]]
            corners = [c - 1 if c > 0 else len(vertices) + c for c in corners]
            faces += [[corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1)]
    return np.asarray(vertices, dtype=np.float32).reshape(-1, 3), np.asarray(faces, dtype=np.int32).reshape(-1, 3)


def vertex_normals(points: npt.NDArray[np.floating], faces: npt.NDArray[np.integer]) -> npt.NDArray[np.float64]:
    """Each vertex's normal: the area-weighted mean of its triangles' (unit length; +z where none)."""
    corners = points[faces].astype(np.float64)
    weighted = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # twice the area
    normals = np.zeros((len(points), 3))
    for k in range(3):
        np.add.at(normals, faces[:, k], weighted)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(length > 0, normals / np.where(length > 0, length, 1), [0.0, 0.0, 1.0])


def obj_bytes(
    points: npt.NDArray[np.floating], faces: npt.NDArray[np.integer], materials: tuple[str, str] | None
) -> bytes:
    """An OBJ of `points` and triangles `faces` with smooth normals (`materials`: its library's file
    name and the material the faces use)."""
    lines = ["# robocog: an arm's visual mesh, simplified (server/world/arm_visuals.py)"]
    if materials is not None:
        lines.append(f"mtllib {materials[0]}")
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in points]
    lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in vertex_normals(points, faces)]
    if materials is not None:
        lines.append(f"usemtl {materials[1]}")
    lines += [f"f {a + 1}//{a + 1} {b + 1}//{b + 1} {c + 1}//{c + 1}" for a, b, c in faces]
    return ("\n".join(lines) + "\n").encode()


def _materials(source: Path, text: str, library_copy: Path) -> tuple[str, str] | None:
    """The source's material library, copied to `library_copy` (beside the simplified mesh), and its
    first material used."""
    library = re.search(r"^mtllib\s+(\S+)", text, re.M)
    used = re.search(r"^usemtl\s+(\S+)", text, re.M)
    if library is None or used is None or not (source.parent / library.group(1)).is_file():
        return None
    write_once(library_copy, (source.parent / library.group(1)).read_bytes())
    return library_copy.name, used.group(1)
