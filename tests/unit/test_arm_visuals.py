"""The arm's visual meshes are simplified to a tenth of their triangles (`arm_visuals`: 3.8 MB less in
every world of a fleet) and the arm still looks the same to the camera: same outline, same colours."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world import arm_visuals, urdf
from robocog.server.world.world import World
from robocog.shared.robot_spec import RobotSpec, resolve_urdf

SIDE = (320, 240)


def _triangles(path: Path) -> int:
    return len(arm_visuals.parse_obj(path.read_text(encoding="utf-8"))[1])


def test_the_arms_visual_meshes_are_simplified(world: World) -> None:
    shapes = world.client.getVisualShapeData(world.sim.robot.arm)
    meshes = [Path(shape[4].decode()) for shape in shapes]
    assert len(meshes) == 8 and all(p.parent.name == "robocog-urdf" and p.suffix == ".obj" for p in meshes), meshes
    source = resolve_urdf(world.robot_spec.arm.urdf).parent / "meshes"
    for mesh in meshes:
        original = _triangles(source / f"{mesh.stem.rsplit('-', 1)[0]}.obj")
        assert original * 0.08 < _triangles(mesh) < original * 0.12, mesh  # a tenth of 1,100 to 3,000
    materials = [shape[7] for shape in shapes]
    assert {tuple(round(c, 2) for c in rgba) for rgba in materials} == {
        (0.2, 0.2, 0.2, 1.0),
        (0.5, 0.7, 1.0, 1.0),
        (1.0, 0.42, 0.04, 1.0),
    }


def test_a_simplified_mesh_is_written_again_when_it_has_gone(world: World) -> None:
    mesh = Path(world.client.getVisualShapeData(world.sim.robot.arm)[1][4].decode())
    before = mesh.read_bytes()
    mesh.unlink()
    source = resolve_urdf(world.robot_spec.arm.urdf).parent / "meshes" / f"{mesh.stem.rsplit('-', 1)[0]}.obj"
    assert arm_visuals.simplified_obj(source) == mesh and mesh.read_bytes() == before  # the same bytes


def test_small_meshes_and_other_files_are_kept(tmp_path: Path) -> None:
    small = tmp_path / "small.obj"
    small.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n", encoding="utf-8")
    stl = tmp_path / "box.stl"
    stl.write_bytes(b"solid\n")
    assert arm_visuals.simplified_obj(small) == small
    assert arm_visuals.simplified_obj(stl) == stl
    assert arm_visuals.simplified_obj(tmp_path / "absent.obj") == tmp_path / "absent.obj"


def test_parse_obj_makes_fans_of_polygons_and_reads_negative_indices() -> None:
    text = "o quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4/1/1 -3/2/1 -1/3/1\n"
    points, faces = arm_visuals.parse_obj(text)
    assert points.shape == (4, 3)
    assert faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 3]]
    normals = arm_visuals.vertex_normals(points, faces[:2])
    assert np.allclose(normals, [[0, 0, 1]] * 4)


@pytest.fixture(scope="module")
def arms(shared_world: World) -> Iterator[list[tuple[BulletClient, int]]]:
    """The arm in two clients of its own: as the world loads it, and with pybullet_data's visual meshes."""
    spec: RobotSpec = shared_world.robot_spec
    simple = urdf.derived_urdf(spec)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(arm_visuals, "simplified_obj", lambda source: source)
        urdf._derived.cache_clear()
        original = urdf.derived_urdf(spec)
    urdf._derived.cache_clear()
    assert original != simple
    clients = [BulletClient(pybullet.DIRECT) for _ in range(2)]
    try:
        yield [(c, c.loadURDF(str(u), useFixedBase=True)) for c, u in zip(clients, (simple, original), strict=True)]
    finally:
        for c in clients:
            c.disconnect()


def _picture(c: BulletClient, arm: int, yaw: float) -> tuple[npt.NDArray[np.int16], npt.NDArray[np.bool_]]:
    view = c.computeViewMatrixFromYawPitchRoll([0, 0, 0.6], 1.4, yaw, -20, 0, 2)
    projection = c.computeProjectionMatrixFOV(50, SIDE[0] / SIDE[1], 0.05, 10)
    _, _, rgb, _, seg = c.getCameraImage(*SIDE, view, projection, renderer=pybullet.ER_TINY_RENDERER)
    picture = np.asarray(rgb, dtype=np.int16).reshape(SIDE[1], SIDE[0], 4)[..., :3]
    return picture, np.asarray(seg).reshape(SIDE[1], SIDE[0]) == arm


def test_the_arm_looks_the_same_to_the_camera(arms: list[tuple[BulletClient, int]]) -> None:
    rng = np.random.default_rng(3)
    for _ in range(4):
        pose = rng.uniform(-1.5, 1.5, 7)
        for c, arm in arms:
            for joint, angle in enumerate(pose):
                c.resetJointState(arm, joint, angle)
        for yaw in (0, 90, 200):
            (simple, simple_mask), (original, original_mask) = (_picture(c, arm, yaw) for c, arm in arms)
            both = simple_mask & original_mask
            assert original_mask.sum() > 2000  # the arm fills a good part of the picture
            assert both.sum() / (simple_mask | original_mask).sum() > 0.95  # its outline
            assert np.abs(simple - original)[both].mean() < 8  # its colours and shading: 4 to 5 of 255
