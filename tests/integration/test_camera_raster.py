"""The camera's cheaper frame: drawn at 3/4 of each side and scaled up, without the robot's arm when
the arm is out of the frame. What must hold: the picture stays the full-size one's (bar the scaling's
softness), the caption (from the body ids) names the same things, and the arm is hidden only where
it cannot be seen and comes back with its own colours.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pybullet
import pytest

from robocog.server.world import camera, raster
from robocog.server.world.world import World

PLACES = ["Front Door", "Kitchen Area Left", "Kitchen Table", "Living Room"]


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    with World() as w:
        yield w


def test_a_scaled_frame_shows_and_captions_what_the_full_size_one_does(world: World) -> None:
    here = world.robot_location()
    for place in PLACES:
        path = world.map.shortest_path(here, place)
        assert path is not None
        world.drive(path)
        here = place
        for direction in [*camera.DIRECTIONS, "mug", "tv"]:
            scaled, full = camera.capture(world, direction), camera.capture(world, direction, scale=1.0)
            assert scaled.rgb.shape == full.rgb.shape == (camera.HEIGHT, camera.WIDTH, 3)
            assert scaled.segmentation.shape == scaled.depth_m.shape == (camera.HEIGHT, camera.WIDTH)
            difference = np.abs(scaled.rgb.astype(int) - full.rgb.astype(int)).mean()
            assert difference < 8, (place, direction, difference)  # edges soften; nothing moves or recolours
            said, truth = camera.caption(world, scaled), camera.caption(world, full)
            named, true_names = {o.name for o in said.objects}, {o.name for o in truth.objects}
            assert named <= true_names, (place, direction)  # nothing the full-size frame does not show
            # A body at the threshold (the mug seen from the Front Door: 6 pixels of 76,800) may drop
            # out; whatever shows clearly is named.
            clear = {o for o in true_names if pixels(world, full, o) >= 2 * camera.MIN_PIXELS}
            assert clear <= named, (place, direction)
            assert set(said.furniture) <= set(truth.furniture) and said.locations == truth.locations
            assert said.furniture == [f for f in truth.furniture if f in said.furniture], (place, direction)


def pixels(world: World, view: camera.CameraView, name: str) -> int:
    return int(np.count_nonzero(view.segmentation == world.sim.objects[name].body))


def test_bilinear_scaling_keeps_flat_colour_and_blends_only_between_neighbours() -> None:
    flat = np.full((18, 24, 3), (200, 100, 7), dtype=np.uint8)
    assert np.array_equal(raster.bilinear(flat, 24, 32), np.full((24, 32, 3), (200, 100, 7), dtype=np.uint8))
    halves = np.zeros((18, 24, 3), dtype=np.uint8)
    halves[:, 12:] = 240
    row = raster.bilinear(halves, 24, 32)[0, :, 0]
    assert row[0] == 0 and row[-1] == 240 and list(row) == sorted(row)  # a ramp at the edge, no overshoot
    assert raster.bilinear(flat, 18, 24) is flat
    assert list(raster.nearest(3, 4)) == [0, 1, 1, 2] and raster.render_size(320) == 240
    assert raster.render_size(16) == 16  # never below the smallest image


def test_the_arm_is_hidden_only_out_of_the_frame_and_keeps_its_colours(world: World) -> None:
    client, robot = world.sim.client, world.sim.robot
    projection = client.computeProjectionMatrixFOV(60, 4 / 3, 0.05, 25)
    at_arm = client.computeViewMatrix([robot.x + 1.5, robot.y + 1.0, 1.2], [robot.x, robot.y, 0.6], [0, 0, 1])
    away = client.computeViewMatrix([robot.x + 1.5, robot.y + 1.0, 1.2], [robot.x + 5, robot.y + 5, 1.2], [0, 0, 1])

    def arm_pixels() -> tuple[int, bytes]:
        _, _, rgba, _, seg = client.getCameraImage(
            160, 120, at_arm, projection, renderer=pybullet.ER_TINY_RENDERER, shadow=0
        )
        ids = np.asarray(seg) & ((1 << 24) - 1)
        return int(np.count_nonzero(ids == robot.arm)), np.asarray(rgba).tobytes()

    seen, picture = arm_pixels()
    assert seen > 100
    with raster.arm_hidden_unless_seen(client, robot.arm, at_arm, projection):
        assert arm_pixels() == (seen, picture)  # in the frame: drawn
    with raster.arm_hidden_unless_seen(client, robot.arm, away, projection):
        assert arm_pixels()[0] == 0  # out of the frame: skipped
    assert arm_pixels() == (seen, picture)  # and back, in its own colours
