"""The arm's derived URDF: box collisions that bound the meshes they replace, and the same arm."""

from __future__ import annotations

import re
import struct

import numpy as np
import pybullet
import pytest

from robocog.assets import ASSETS_DIR
from robocog.server.world.builder import connect
from robocog.server.world.urdf import boxed_collision, derived_urdf, mesh_bounds
from robocog.shared.robot_spec import load_robot, resolve_urdf

#: PyBullet pads a mesh's bounds by its collision margin (about 2 mm) and a box's a little less.
MARGIN = 4e-3


@pytest.fixture(scope="module")
def spec():  # type: ignore[no-untyped-def]
    return load_robot(ASSETS_DIR / "robot" / "iiwa_mobile.yaml")


def test_every_collision_mesh_becomes_a_box_and_the_rest_is_the_same(spec) -> None:  # type: ignore[no-untyped-def]
    text = derived_urdf(spec).read_text(encoding="utf-8")
    source = resolve_urdf(spec.arm.urdf).read_text(encoding="utf-8")
    collisions = re.findall(r"<collision>.*?</collision>", text, re.S)
    assert collisions and all("<box size=" in c and "<mesh" not in c for c in collisions)
    visuals = re.findall(r"<visual>.*?</visual>", text, re.S)
    assert len(visuals) == source.count("<visual>") and all('<mesh filename="/' in v for v in visuals)
    assert re.findall(r"<inertial>.*?</inertial>", text, re.S) == re.findall(r"<inertial>.*?</inertial>", source, re.S)


def test_the_boxes_bound_what_the_meshes_bounded_at_any_pose(spec) -> None:  # type: ignore[no-untyped-def]
    """Each link's world bounds with the box equal those with the mesh at rest, and contain them in
    any pose (the camera's test of whether the arm can be in a frame reads them)."""
    client = connect(gui=False)
    try:
        flags = pybullet.URDF_USE_INERTIA_FROM_FILE
        original = resolve_urdf(spec.arm.urdf)
        meshes = client.loadURDF(str(original), [0, 0, 0], useFixedBase=True, flags=flags)
        boxes = client.loadURDF(str(derived_urdf(spec)), [0, 0, 0], useFixedBase=True, flags=flags)
        joints = range(client.getNumJoints(meshes))
        rng = np.random.default_rng(7)
        for pose in range(6):
            q = [0.0] * len(joints) if pose == 0 else rng.uniform(-1.5, 1.5, len(joints)).tolist()
            for body in (meshes, boxes):
                for j, angle in zip(joints, q, strict=True):
                    client.resetJointState(body, j, angle)
            for link in (-1, *joints):
                (lo_m, hi_m), (lo_b, hi_b) = (np.array(client.getAABB(b, link)) for b in (meshes, boxes))
                assert np.all(lo_b <= lo_m + MARGIN) and np.all(hi_b >= hi_m - MARGIN), (pose, link)
                if pose == 0 and link == -1:
                    assert np.allclose(lo_b, lo_m, atol=2.5e-3) and np.allclose(hi_b, hi_m, atol=2.5e-3)
    finally:
        client.disconnect()


def test_a_rotated_and_scaled_mesh_moves_its_box_with_its_frame(tmp_path) -> None:  # type: ignore[no-untyped-def]
    mesh = tmp_path / "m.obj"
    mesh.write_text("v 0 0 0\nv 2 1 0.5\nv 1 0 0\n", encoding="utf-8")
    block = (
        f'<collision><origin rpy="0 0 1.5707963" xyz="1 0 0"/><geometry><mesh filename="{mesh}" scale="1 2 1"/>'
        "</geometry></collision>"
    )
    boxed = boxed_collision(block)
    assert '<box size="2 2 0.5"/>' in boxed
    xyz = [float(v) for v in re.search(r'xyz="([^"]+)"', boxed).group(1).split()]  # type: ignore[union-attr]
    assert np.allclose(xyz, [0.0, 1.0, 0.25], atol=1e-5)  # the centre (1, 1, .25) turned a quarter about z


def test_a_binary_stl_an_unknown_format_and_a_primitive(tmp_path) -> None:  # type: ignore[no-untyped-def]
    stl = tmp_path / "t.stl"
    triangle = struct.pack("<12fH", 0, 0, 1, -1, 0, 0, 3, 0, 0, 0, 2, 5, 0)
    stl.write_bytes(b"\0" * 80 + struct.pack("<I", 1) + triangle)
    low, high = mesh_bounds(str(stl))  # type: ignore[misc]
    assert low.tolist() == [-1, 0, 0] and high.tolist() == [3, 2, 5]
    assert mesh_bounds(str(tmp_path / "model.dae")) is None
    cylinder = '<collision><geometry><cylinder radius="0.1" length="0.2"/></geometry></collision>'
    assert boxed_collision(cylinder) == cylinder
