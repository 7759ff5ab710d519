"""What keeps a fleet's robots small stays in place, and changes nothing a world computes or shows.

A fleet holds a PyBullet client per robot (`server/robots/fleet.py`); two things a world loaded cost memory
in every one of them and are now built lean (docs/figures.md, Scale):

- the floor is drawn as TinyRenderer's quad for a plane with its checkerboard as 16 x 16 texels, not as
  a plane (for which TinyRenderer makes a 1024 x 1024 texture and copies it: 6 MB a client), and the
  frames are the same to the bit;
- the arm's STL collision meshes keep only their extreme points (`arm_meshes`), and every link's
  bounding box (all the world reads of them: the arm collides with nothing) is the same to the bit.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world import arm_meshes, builder, camera, urdf
from robocog.server.world.world import World
from robocog.shared.robot_spec import resolve_urdf


def _plane_floor(c: BulletClient) -> int:
    """The floor as it was drawn before: a plane's own visual (from its collision shape)."""
    floor = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_PLANE), -1, useMaximalCoordinates=True)
    c.changeVisualShape(floor, -1, rgbaColor=[0.9, 0.9, 0.88, 1])
    return floor


def test_the_floor_is_not_drawn_as_a_plane(world: World) -> None:
    (shape,) = world.client.getVisualShapeData(world.sim.floor)
    assert shape[2] == pybullet.GEOM_MESH  # a plane's visual brings the 1024 x 1024 texture


@pytest.fixture(scope="module")
def plane_world() -> Iterator[World]:
    """The household with its floor drawn as a plane, as every world was before."""
    with pytest.MonkeyPatch.context() as patch, World() as world:
        patch.setattr(builder, "make_floor", _plane_floor)
        world.reset()  # built again, with the plane
        yield world


@pytest.mark.parametrize("direction", ["ahead", "left", "behind", "Kitchen Table"])
def test_frames_are_the_same_as_with_a_plane_floor(world: World, plane_world: World, direction: str) -> None:
    (shape,) = plane_world.client.getVisualShapeData(plane_world.sim.floor)
    assert shape[2] == pybullet.GEOM_PLANE
    for scale in (None, 1.0):
        lean, plane = camera.capture(world, direction, scale=scale), camera.capture(plane_world, direction, scale=scale)
        assert (lean.segmentation == world.sim.floor).sum() > 1000  # the floor is in the picture
        assert np.array_equal(lean.rgb, plane.rgb)
        assert np.array_equal(lean.segmentation, plane.segmentation)
        assert np.array_equal(lean.depth_m, plane.depth_m)


def _triangles(path: Path) -> int:
    return int(struct.unpack_from("<I", path.read_bytes(), 80)[0])


def test_the_arms_collision_meshes_are_reduced(world: World) -> None:
    shapes = [world.client.getCollisionShapeData(world.sim.robot.arm, link)[0] for link in range(-1, 7)]
    meshes = [Path(shape[4].decode()) for shape in shapes]
    assert all(p.parent.name == "robocog-urdf" and p.suffix == ".stl" for p in meshes), meshes
    source = Path(resolve_urdf(world.robot_spec.arm.urdf)).parent / "meshes"
    for mesh in meshes:
        original = source / f"{mesh.stem.rsplit('-', 1)[0]}.stl"
        assert _triangles(mesh) * 10 < _triangles(original), mesh  # 9,000 points become a few hundred


def test_the_derived_urdf_is_derived_once_and_written_again_when_it_has_gone(world: World) -> None:
    first = urdf.derived_urdf(world.robot_spec)
    assert urdf.derived_urdf(world.robot_spec) == first and urdf._derived.cache_info().hits >= 1
    first.unlink()
    again = urdf.derived_urdf(world.robot_spec)
    assert again == first and again.is_file()


def test_derived_meshes_that_have_gone_are_written_again_at_the_next_reset(world: World) -> None:
    """A temporary directory may be cleaned, file by file, under a running server."""
    arm = world.sim.robot.arm
    collision = Path(world.client.getCollisionShapeData(arm, 2)[0][4].decode())
    visual = Path(world.client.getVisualShapeData(arm)[3][4].decode())
    before = collision.read_bytes(), visual.read_bytes()
    collision.unlink()
    visual.unlink()
    world.reset()  # loads the arm again
    assert (collision.read_bytes(), visual.read_bytes()) == before
    arm = world.sim.robot.arm
    assert Path(world.client.getCollisionShapeData(arm, 2)[0][4].decode()) == collision


def test_extreme_points_keep_the_bounding_box_to_the_bit() -> None:
    points = np.random.default_rng(0).normal(size=(5000, 3)).astype(np.float32)
    kept = arm_meshes.extreme_points(points)
    assert len(kept) < 600
    assert np.array_equal(kept.min(axis=0), points.min(axis=0))
    assert np.array_equal(kept.max(axis=0), points.max(axis=0))


def test_the_arms_bounding_boxes_are_the_same_as_with_the_original_meshes(world: World) -> None:
    lean_urdf = urdf.derived_urdf(world.robot_spec)
    lean = arm_meshes.reduced_stl
    arm_meshes.reduced_stl = lambda source: source  # the URDF as derived before: pybullet_data's own meshes
    urdf._derived.cache_clear()
    try:
        original_urdf = urdf.derived_urdf(world.robot_spec)
    finally:
        arm_meshes.reduced_stl = lean
        urdf._derived.cache_clear()
    assert original_urdf != lean_urdf
    clients = [BulletClient(pybullet.DIRECT) for _ in range(2)]
    try:
        arms = [
            (c, c.loadURDF(str(u), [1, 2, 0.3], useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE))
            for c, u in zip(clients, (lean_urdf, original_urdf), strict=True)
        ]
        rng = np.random.default_rng(1)
        for _ in range(50):
            q, xyz, yaw = rng.uniform(-3, 3, 7), rng.uniform(-5, 5, 3), rng.uniform(-3, 3)
            boxes = []
            for c, arm in arms:
                c.resetBasePositionAndOrientation(arm, xyz, c.getQuaternionFromEuler([0, 0, yaw]))
                for joint, angle in enumerate(q):
                    c.resetJointState(arm, joint, angle)
                boxes.append([c.getAABB(arm, link) for link in range(-1, c.getNumJoints(arm))])
            assert boxes[0] == boxes[1]
    finally:
        for c in clients:
            c.disconnect()
