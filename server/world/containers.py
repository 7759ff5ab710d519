"""Furniture that opens, in physics: each container one multibody, its carcass the fixed base and its
drawer or door link 0 on a prismatic or revolute joint, built from `robocog.shared.containers`'s panels
(no meshes). A position motor with a force limit holds the joint where it is, so a door does not swing
by itself, and drives it when the robot opens or closes it; what stops it is physics.

The queries here read the physics state only: a joint's position, whether it is closed, and which
container's interior holds a point (a drawer's interior slides out with it).
"""

from __future__ import annotations

import pybullet
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world.sim import ContainerBody, Sim
from robocog.shared.containers import Geometry, Panel, geometry
from robocog.shared.scene import Container

#: The motor's force limit: newtons on a drawer, newton-metres on a door. A light object in the way is
#: pushed aside; a heavy or fixed one stops the joint short, and the robot reports it blocked.
DRAWER_FORCE_N = 40.0
DOOR_TORQUE_NM = 12.0
#: How fast the motor moves the joint: metres or radians per second.
DRAWER_SPEED = 0.25
DOOR_SPEED = 0.8
MOVING_MASS_KG = 2.0


def build(c: BulletClient, spec: Container) -> ContainerBody:
    """The container's multibody, closed and held closed."""
    g = geometry(spec)
    base_col, base_vis = _shapes(c, g.carcass, spec.color)
    link_col, link_vis = _shapes(c, g.moving, spec.color)
    body = c.createMultiBody(
        baseMass=0,
        baseCollisionShapeIndex=base_col,
        baseVisualShapeIndex=base_vis,
        basePosition=list(spec.center),
        linkMasses=[MOVING_MASS_KG],
        linkCollisionShapeIndices=[link_col],
        linkVisualShapeIndices=[link_vis],
        linkPositions=[list(g.joint_origin)],
        linkOrientations=[[0, 0, 0, 1]],
        linkInertialFramePositions=[[0, 0, 0]],
        linkInertialFrameOrientations=[[0, 0, 0, 1]],
        linkParentIndices=[0],
        linkJointTypes=[pybullet.JOINT_PRISMATIC if g.joint == "prismatic" else pybullet.JOINT_REVOLUTE],
        linkJointAxis=[list(g.axis)],
    )
    for link in (-1, 0):
        c.changeDynamics(body, link, lateralFriction=0.9)
    c.changeDynamics(body, 0, jointDamping=0.5, linearDamping=0.1, angularDamping=0.1)
    box = ContainerBody(g, body)
    hold(c, box, 0.0)
    return box


def _shapes(c: BulletClient, panels: tuple[Panel, ...], color: tuple[float, ...]) -> tuple[int, int]:
    n = len(panels)
    halves = [list(p.half) for p in panels]
    frames = [list(p.center) for p in panels]
    col = c.createCollisionShapeArray([pybullet.GEOM_BOX] * n, halfExtents=halves, collisionFramePositions=frames)
    vis = c.createVisualShapeArray([pybullet.GEOM_BOX] * n, halfExtents=halves, visualFramePositions=frames)
    return col, vis


def force(g: Geometry) -> float:
    return DRAWER_FORCE_N if g.joint == "prismatic" else DOOR_TORQUE_NM


def speed(g: Geometry) -> float:
    return DRAWER_SPEED if g.joint == "prismatic" else DOOR_SPEED


def hold(c: BulletClient, box: ContainerBody, target: float) -> None:
    """Have the joint's motor drive it to `target` (and hold it there), within its force limit."""
    g = box.geometry
    c.setJointMotorControl2(
        box.body,
        0,
        pybullet.POSITION_CONTROL,
        targetPosition=target,
        targetVelocity=0.0,
        force=force(g),
        maxVelocity=speed(g),
        positionGain=0.3,
        velocityGain=1.0,
    )


def is_closed(sim: Sim, name: str) -> bool:
    return sim.containers[name].geometry.is_closed(sim.joint(name))


def opening(sim: Sim, name: str) -> float:
    """How far open, from 0 (closed) to 1 (fully open)."""
    g = sim.containers[name].geometry
    return max(0.0, min(1.0, sim.joint(name) / g.open_q))


def interior(sim: Sim, name: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The low and high corners (world) of the container's interior now."""
    g = sim.containers[name].geometry
    lo, hi = g.interior
    dx, dy = 0.0, 0.0
    if g.interior_moves:
        q = sim.joint(name)
        dx, dy = g.facing[0] * q, g.facing[1] * q
    cx, cy, cz = g.spec.center
    return (cx + lo[0] + dx, cy + lo[1] + dy, cz + lo[2]), (cx + hi[0] + dx, cy + hi[1] + dy, cz + hi[2])


def container_at(sim: Sim, xyz: tuple[float, float, float]) -> str | None:
    """The container whose interior holds the point `xyz` now, if any."""
    for name in sim.containers:
        lo, hi = interior(sim, name)
        if all(lo[i] - 1e-3 <= xyz[i] <= hi[i] + 1e-3 for i in range(3)):
            return name
    return None


def handle(sim: Sim, name: str) -> tuple[float, float, float]:
    """Where the handle is now (world): the link's frame moved by the joint, then the handle's offset."""
    box = sim.containers[name]
    pos, orn = sim.client.getLinkState(box.body, 0, computeForwardKinematics=True)[4:6]
    point, _ = sim.client.multiplyTransforms(pos, orn, box.geometry.handle, [0, 0, 0, 1])
    return (float(point[0]), float(point[1]), float(point[2]))


def touching(sim: Sim, name: str) -> list[str]:
    """The objects touching the container's drawer or door now (what may be in its way), in scene order."""
    body = sim.containers[name].body
    return [
        obj_name
        for obj_name, obj in sim.objects.items()
        if sim.client.getContactPoints(body, obj.body, linkIndexA=0)
        or sim.client.getClosestPoints(body, obj.body, 0.005, linkIndexA=0)
    ]
