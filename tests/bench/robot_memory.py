"""Where a fleet robot's memory goes: one part, measured in a fresh process (`python robot_memory.py PART`).

The process builds `N` of the part after one of it (imports, caches and the renderer's first frame
paid before the clock) and prints the growth of its RSS per copy, in MB:

- `client`: an empty PyBullet DIRECT client (`resetSimulation` done, as `World` has it);
- `floor_plane` / `floor`: such a client with the floor drawn as a plane (as it was) / as the world
  draws it now (`builder.make_floor`), the client itself not counted;
- `arm_original` / `arm`: the same with the arm loaded from pybullet_data's collision and visual
  meshes (as it was) / from the reduced collision meshes (`arm_meshes`) and the simplified visual
  ones (`arm_visuals`);
- `world_original` / `world`: a whole `World` (the household, built and settled) as it was built
  before (a plane floor, the original arm meshes) / as it is built now;
- `robot`: a fleet's robot: a `RobotSession` on its own world, after a `look_around` and a camera frame.

`python robot_memory.py --figure PATH` draws the arm from three sides with pybullet_data's visual
meshes (top) and the simplified ones (bottom), as TinyRenderer draws them (docs/arm-visuals.png).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pybullet
from pybullet_utils.bullet_client import BulletClient

N = 16
PARTS = ("client", "floor_plane", "floor", "arm_original", "arm", "world_original", "world", "robot")


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


def _original_mesh(source: Path) -> Path:
    return source


def _client() -> BulletClient:
    client = BulletClient(pybullet.DIRECT)
    client.resetSimulation()
    return client


def _builder(part: str) -> tuple[Callable[[Any], Any], bool]:
    """How to build one copy of `part` (into the client given, when the second item is True)."""
    from robocog.server.config import SessionConfig
    from robocog.server.robots.session import RobotSession
    from robocog.server.tools import look_around
    from robocog.server.world import arm_meshes, arm_visuals, builder, camera, urdf
    from robocog.server.world.world import DEFAULT_SCENE, World
    from robocog.shared.robot_spec import load_robot
    from robocog.shared.scene_files import load_scene

    def arm_urdf(reduced: bool) -> str:
        spec = load_robot(load_scene(DEFAULT_SCENE).robot_file())
        lean, simple = arm_meshes.reduced_stl, arm_visuals.simplified_obj
        if not reduced:
            arm_meshes.reduced_stl = arm_visuals.simplified_obj = _original_mesh  # pybullet_data's own meshes
        urdf._derived.cache_clear()
        try:
            return str(urdf.derived_urdf(spec))
        finally:
            arm_meshes.reduced_stl, arm_visuals.simplified_obj = lean, simple
            urdf._derived.cache_clear()

    def plane(c: BulletClient) -> int:
        floor = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_PLANE), -1, useMaximalCoordinates=True)
        c.changeVisualShape(floor, -1, rgbaColor=[0.9, 0.9, 0.88, 1])
        return floor

    if part == "world_original":  # every world of this process built as before
        builder.make_floor = plane
        arm_meshes.reduced_stl = arm_visuals.simplified_obj = _original_mesh
        urdf._derived.cache_clear()

    def fleet_robot(_: object) -> RobotSession:
        session = RobotSession(SessionConfig())
        session.call(look_around.TOOL)
        camera.capture(session.world)
        return session

    if part in ("arm", "arm_original"):
        arm = arm_urdf(part == "arm")
        return lambda c: c.loadURDF(arm, useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE), True
    if part in ("floor", "floor_plane"):
        return (builder.make_floor if part == "floor" else plane), True
    if part in ("world", "world_original"):
        return lambda _: World(), False
    if part == "robot":
        return fleet_robot, False
    return lambda _: _client(), False


def measure(part: str) -> float:
    """The growth of RSS per copy of `part`, in MB, over `N` copies after the first."""
    build, into_client = _builder(part)
    clients = [_client() if into_client else None for _ in range(N + 1)]
    keep = [build(clients[0])]
    before = rss_mb()
    keep += [build(c) for c in clients[1:]]
    return round((rss_mb() - before) / N, 2)


def draw_arms(path: Path) -> None:
    """The arm from three sides, with pybullet_data's visual meshes (top row) and the simplified ones."""
    import numpy as np
    from PIL import Image

    from robocog.server.world import arm_visuals, urdf
    from robocog.server.world.world import DEFAULT_SCENE
    from robocog.shared.robot_spec import load_robot
    from robocog.shared.scene_files import load_scene

    spec = load_robot(load_scene(DEFAULT_SCENE).robot_file())
    simple, rows = arm_visuals.simplified_obj, []
    for original in (True, False):
        arm_visuals.simplified_obj = _original_mesh if original else simple
        urdf._derived.cache_clear()
        client = _client()
        arm = client.loadURDF(str(urdf.derived_urdf(spec)), useFixedBase=True)
        for joint, angle in enumerate((0.4, 0.9, -0.3, -1.2, 0.5, 1.0, 0.0)):
            client.resetJointState(arm, joint, angle)
        row = []
        for yaw in (30, 150, 270):
            view = client.computeViewMatrixFromYawPitchRoll([0, 0, 0.6], 1.5, yaw, -20, 0, 2)
            projection = client.computeProjectionMatrixFOV(50, 4 / 3, 0.05, 10)
            _, _, rgb, _, _ = client.getCameraImage(320, 240, view, projection, renderer=pybullet.ER_TINY_RENDERER)
            row.append(np.asarray(rgb, dtype=np.uint8).reshape(240, 320, 4)[..., :3])
        rows.append(np.hstack(row))
        client.disconnect()
    arm_visuals.simplified_obj = simple
    urdf._derived.cache_clear()
    Image.fromarray(np.vstack(rows)).save(path, optimize=True)


if __name__ == "__main__":
    if sys.argv[1] == "--figure":
        draw_arms(Path(sys.argv[2]))
    else:
        print(json.dumps({sys.argv[1]: measure(sys.argv[1])}))
