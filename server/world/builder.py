"""Scene building: a PyBullet client, and the bodies of a scene (floor, walls, furniture, objects, robot).

`build` creates every body in the scene's order (the order is part of what makes a seed give the
same world), puts the objects at their start poses from the YAML and lets them settle.
"""

from __future__ import annotations

import math
import os

import pybullet
import pybullet_data
from pybullet_utils.bullet_client import BulletClient

from robocog.assets import ASSETS_DIR
from robocog.server.world import containers
from robocog.server.world.cstdio import c_output_discarded
from robocog.server.world.navigation import SemanticMap
from robocog.server.world.robot import Robot
from robocog.server.world.sim import Body, Position, Sim
from robocog.shared.errors import WorldError
from robocog.shared.robot_spec import RobotSpec, resolve_urdf
from robocog.shared.scene import Scene, SceneObject, Wall


def connect(gui: bool) -> BulletClient:
    """A PyBullet client of its own (headless unless `gui`), with pybullet_data on its search path."""
    if gui and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise WorldError(
            "the PyBullet GUI needs a display, and none is set (DISPLAY is empty); "
            "run headless (the default) or start an X server such as Xvfb"
        )
    with c_output_discarded():
        client = BulletClient(connection_mode=pybullet.GUI if gui else pybullet.DIRECT)
    client.setAdditionalSearchPath(pybullet_data.getDataPath())
    return client


def build(client: BulletClient, scene: Scene, robot_spec: RobotSpec) -> Sim:
    """The scene's bodies in `client` (an empty simulation), objects settled at their start poses."""
    c, phys = client, scene.physics
    c.setGravity(0, 0, phys.gravity)
    c.setTimeStep(phys.time_step)
    c.setPhysicsEngineParameter(numSolverIterations=phys.solver_iterations, deterministicOverlappingPairs=1)
    # Maximal coordinates make every body a plain rigid body: about half the cost per step
    # of the default multibody representation, and resting bodies can sleep.
    floor = make_floor(c)
    static_bodies = [floor, *(_wall(c, wall) for wall in scene.walls)]
    parts: dict[str, int] = {"floor": floor}
    part_top: dict[str, float] = {"floor": 0.0}
    for item in scene.furniture:
        for part in item.parts:
            half = [s / 2 for s in part.size]
            col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
            vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=part.color)
            body = c.createMultiBody(0, col, vis, list(part.center), useMaximalCoordinates=True)
            key = f"{item.name}/{part.name}"
            parts[key] = body
            part_top[key] = part.center[2] + part.size[2] / 2
            static_bodies.append(body)
    for body in static_bodies:
        c.changeDynamics(body, -1, lateralFriction=0.9)
    boxes = {spec.name: containers.build(c, spec) for spec in scene.containers}
    for box in boxes.values():
        for link in (-1, 0):
            c.changeVisualShape(box.body, link, rgbaColor=list(box.geometry.spec.color))
        parts[box.name] = box.body
        part_top[box.name] = box.geometry.floor_z
        static_bodies.append(box.body)
    positions = {
        (pos.location, pos.name): Position(
            pos, parts[pos.support], part_top[pos.support], pos.support if pos.support in boxes else None
        )
        for pos in scene.place_positions
    }
    objects = {obj.name: _object(c, obj) for obj in scene.objects}
    start = scene.location(scene.robot_start)
    sim = Sim(
        client=c,
        scene=scene,
        robot_spec=robot_spec,
        map=SemanticMap(scene),
        floor=floor,
        static_bodies=static_bodies,
        parts=parts,
        positions=positions,
        objects=objects,
        robot=Robot(c, robot_spec, start.x, start.y),
        containers=boxes,
    )
    for obj in objects.values():
        _pose_at_start(sim, obj)
    sim.settle()
    return sim


#: The floor's checkerboard as 16 x 16 texels: the four squares TinyRenderer draws a plane with (a
#: 1024 x 1024 texture of them). It samples nearest, so any even size draws the same frames to the
#: bit; 16 keeps the squares' edges sharp where PyBullet's GUI filters textures linearly.
FLOOR_TEXTURE = ASSETS_DIR / "scenes" / "floor.png"
#: TinyRenderer's quad for a plane: 128 m either side of the origin, one texture repeat per metre.
_PLANE_HALF = 128.0
_FLOOR_QUAD = {
    "vertices": [
        [_PLANE_HALF, -_PLANE_HALF, 0],
        [_PLANE_HALF, _PLANE_HALF, 0],
        [-_PLANE_HALF, _PLANE_HALF, 0],
        [-_PLANE_HALF, -_PLANE_HALF, 0],
    ],
    "indices": [0, 1, 2, 0, 2, 3],
    "uvs": [[_PLANE_HALF, _PLANE_HALF], [0, _PLANE_HALF], [0, 0], [_PLANE_HALF, 0]],
    "normals": [[0, 0, 1]] * 4,
}


def make_floor(c: BulletClient) -> int:
    """The floor: a collision plane, drawn as the quad TinyRenderer would draw for it but with its
    checkerboard as 16 x 16 texels: a plane's own visual costs 6 MB per client (a 1024 x 1024 texture
    made for it and copied into the renderer), nearly half of what a world added to its client."""
    vis = c.createVisualShape(pybullet.GEOM_MESH, **_FLOOR_QUAD)
    floor = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_PLANE), vis, useMaximalCoordinates=True)
    c.changeVisualShape(floor, -1, rgbaColor=[0.9, 0.9, 0.88, 1], textureUniqueId=c.loadTexture(str(FLOOR_TEXTURE)))
    return floor


def _wall(c: BulletClient, wall: Wall) -> int:
    (x0, y0), (x1, y1) = wall.start, wall.end
    length = math.hypot(x1 - x0, y1 - y0)
    half = [length / 2 + wall.thickness / 2, wall.thickness / 2, wall.height / 2]
    col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
    vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=[0.75, 0.75, 0.72, 1])
    yaw = math.atan2(y1 - y0, x1 - x0)
    return c.createMultiBody(
        0,
        col,
        vis,
        [(x0 + x1) / 2, (y0 + y1) / 2, wall.height / 2],
        c.getQuaternionFromEuler([0, 0, yaw]),
        useMaximalCoordinates=True,
    )


def _object(c: BulletClient, obj: SceneObject) -> Body:
    if obj.shape == "urdf":
        assert obj.urdf is not None
        body = c.loadURDF(
            str(resolve_urdf(obj.urdf)), [0, 0, 5], globalScaling=obj.urdf_scale, useMaximalCoordinates=True
        )
        c.changeDynamics(body, -1, mass=obj.mass)
        c.changeVisualShape(body, -1, rgbaColor=obj.color)
    else:
        if obj.shape == "box":
            half = [s / 2 for s in obj.size]
            col = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
            vis = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=obj.color)
        else:
            col = c.createCollisionShape(pybullet.GEOM_CYLINDER, radius=obj.size[0] / 2, height=obj.size[2])
            vis = c.createVisualShape(
                pybullet.GEOM_CYLINDER, radius=obj.size[0] / 2, length=obj.size[2], rgbaColor=obj.color
            )
        body = c.createMultiBody(obj.mass, col, vis, [0, 0, 5], useMaximalCoordinates=True)
    c.changeDynamics(
        body,
        -1,
        lateralFriction=0.9,
        rollingFriction=0.001,
        spinningFriction=0.001,
        # Resting bodies sleep (and cost nothing per step) until something touches them.
        activationState=pybullet.ACTIVATION_STATE_ENABLE_SLEEPING,
    )
    c.resetBasePositionAndOrientation(body, [0, 0, 5], [0, 0, 0, 1])
    lo, hi = c.getAABB(body)
    return Body(obj, body, bottom=5 - lo[2], top=hi[2] - 5)


def _pose_at_start(sim: Sim, obj: Body) -> None:
    start = obj.spec.start
    if start.pose is not None:
        x, y, z = start.pose
        sim.put(obj, x, y, z, start.yaw)
    else:
        assert start.location is not None and start.position is not None
        sim.put_on(obj, sim.positions[(start.location, start.position)], start.yaw)
