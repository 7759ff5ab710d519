"""The robot's physical actions over a `Sim`: driving, arm motions, picking up and putting down.

These are motions, not tools: they assume their preconditions hold (the tools in
`robocog.server.tools` check those and word the failures) and report only what physics decides,
as a `Reach`: whether the arm got there, and if not by how much it missed.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Literal

import pybullet

from robocog.server.world import truth
from robocog.server.world.sim import ActionLimit, Grasp, Position, Sim
from robocog.shared.results import ObjectPlacement

Vec3 = tuple[float, float, float]

#: Called with (done, total, message) while a long action runs.
ProgressFn = Callable[[float, float, str], None]


@dataclass(frozen=True)
class Reach:
    """How a pick or put-down motion ended.

    `failure`: "unreachable" (inverse kinematics cannot bring the hand there; nothing moved),
    "missed" (the hand stopped short of the object; the arm went back to rest) or
    "landed_elsewhere" (the object was let go but did not come to rest on the position).
    """

    ok: bool
    failure: Literal["unreachable", "missed", "landed_elsewhere"] | None = None
    gap_m: float = 0.0  # the IK error for "unreachable", the hand's gap to the object for "missed"
    placement: ObjectPlacement | None = None  # put_down: where the object came to rest


# --- base ----------------------------------------------------------------------------------------


def drive_steps(sim: Sim, path: list[str]) -> int:
    """The simulated steps driving along `path` takes."""
    step_len = sim.robot_spec.base_speed * sim.scene.physics.time_step
    return sum(max(1, math.ceil(sim.map.distance(a, b) / step_len)) for a, b in itertools.pairwise(path))


def drive(sim: Sim, path: list[str], progress: ProgressFn | None = None) -> float:
    """Drive the base along `path` (location names), one segment after another; the metres driven.

    A drive the running action cannot pay for in steps is refused before the robot moves; one stopped
    on the way (`ActionLimit`: past its wall time, or the server shutting down) leaves the robot at the
    last location it reached, where it only ever stands."""
    robot = sim.robot
    step_len = sim.robot_spec.base_speed * sim.scene.physics.time_step
    metres = sum(sim.map.distance(a, b) for a, b in itertools.pairwise(path))
    sim.budget.afford(drive_steps(sim, path), f"driving {metres:,.1f} m from {path[0]} to {path[-1]}")
    driven = 0.0
    for i, (a, b) in enumerate(itertools.pairwise(path)):
        (ax, ay), (bx, by) = sim.map.points[a], sim.map.points[b]
        n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / step_len))
        try:
            for k in range(1, n + 1):
                robot.set_base(ax + (bx - ax) * k / n, ay + (by - ay) * k / n, robot.yaw)
                sim.step()
        except ActionLimit:
            robot.set_base(ax, ay, robot.yaw)
            raise
        driven += math.hypot(bx - ax, by - ay)
        if progress is not None:
            progress(i + 1, len(path) - 1, f"reached {b}")
    return driven


# --- arm -----------------------------------------------------------------------------------------


def follow(sim: Sim, trajectory: Iterable[tuple[list[float], list[float]]]) -> None:
    for q, dq in trajectory:
        sim.robot.set_joints(q, dq)
        sim.step()


def move_arm(sim: Sim, q: list[float]) -> None:
    follow(sim, sim.robot.joint_trajectory(q, sim.scene.physics.time_step))


def move_hand_straight(sim: Sim, start: Vec3, end: Vec3) -> None:
    """Move the hand along a straight line (IK at a few waypoints, joint interpolation between)."""
    n = max(1, math.ceil(math.dist(start, end) / 0.1))
    for i in range(1, n + 1):
        waypoint = tuple(a + (b - a) * i / n for a, b in zip(start, end, strict=True))
        q, _ = sim.robot.solve_ik(waypoint)  # type: ignore[arg-type]
        move_arm(sim, q)


def approach_point(sim: Sim, target: Vec3) -> Vec3:
    """A point in line between the base and `target`, just outside the base, slightly higher."""
    robot = sim.robot
    dx, dy = target[0] - robot.x, target[1] - robot.y
    dist = math.hypot(dx, dy)
    keep = min(dist, max(sim.robot_spec.base_size[:2]) * 0.5 + 0.1)
    return (robot.x + dx / dist * keep, robot.y + dy / dist * keep, target[2] + 0.03)


# --- grasping ------------------------------------------------------------------------------------


def attach(sim: Sim, name: str) -> None:
    """Fix the object `name` to the hand where it is now."""
    c, robot, body = sim.client, sim.robot, sim.objects[name].body
    sim.wake(body)
    hand_pos, hand_orn = robot.end_effector_pose()
    obj_pos, obj_orn = c.getBasePositionAndOrientation(body)
    inv_pos, inv_orn = c.invertTransform(hand_pos, hand_orn)
    rel_pos, rel_orn = c.multiplyTransforms(inv_pos, inv_orn, obj_pos, obj_orn)
    constraint = c.createConstraint(
        robot.arm,
        robot.ee,
        body,
        -1,
        pybullet.JOINT_FIXED,
        [0, 0, 0],
        parentFramePosition=rel_pos,
        childFramePosition=[0, 0, 0],
        parentFrameOrientation=rel_orn,
    )
    c.changeConstraint(constraint, maxForce=500)
    sim.grasp = Grasp(name, constraint)


def release(sim: Sim) -> None:
    """Let go of the held object (if any)."""
    if sim.grasp is None:
        return
    constraint = sim.grasp.constraint
    sim.grasp = None
    with contextlib.suppress(pybullet.error):
        sim.client.removeConstraint(constraint)


def pick(sim: Sim, name: str) -> Reach:
    """Reach for the object `name` from where the robot stands, attach it and lift it to the carry pose."""
    c, robot, spec = sim.client, sim.robot, sim.robot_spec
    body = sim.objects[name].body
    (x, y, _), _ = c.getBasePositionAndOrientation(body)
    grasp_point = (x, y, c.getAABB(body)[1][2] + spec.grasp_clearance)
    _, err = robot.solve_ik(grasp_point)
    if err > spec.grasp_threshold:
        return Reach(ok=False, failure="unreachable", gap_m=err)
    approach = approach_point(sim, grasp_point)
    if any(_in_drawer(sim, pos) and sim.holds_xy(pos, x, y) for pos in sim.positions.values()):
        approach = (x, y, grasp_point[2] + DRAWER_LIFT)  # from above, over the drawer's front
    lifted = (grasp_point[0], grasp_point[1], grasp_point[2] + 0.03)
    move_arm(sim, robot.solve_ik(approach)[0])
    move_hand_straight(sim, approach, lifted)
    move_hand_straight(sim, lifted, grasp_point)
    hand = robot.end_effector()
    (x, y, _), _ = c.getBasePositionAndOrientation(body)
    top = (x, y, c.getAABB(body)[1][2])
    gap = math.dist(hand, top)
    if gap > spec.grasp_threshold + spec.grasp_clearance:
        move_arm(sim, list(spec.arm.rest_pose))
        return Reach(ok=False, failure="missed", gap_m=gap)
    attach(sim, name)
    move_hand_straight(sim, grasp_point, lifted)
    move_hand_straight(sim, lifted, approach)
    move_arm(sim, list(spec.arm.carry_pose))
    return Reach(ok=True)


#: How high above a drawer's tray the hand comes before it lowers an object in (the front is 0.35 m or less).
DRAWER_LIFT = 0.3


def _in_drawer(sim: Sim, pos: Position) -> bool:
    """Whether a place position lies in a drawer's tray (whose front stands between the robot and it)."""
    return pos.container is not None and sim.containers[pos.container].geometry.interior_moves


def held_where_gripped(sim: Sim) -> tuple[Vec3, Vec3]:
    """The hand's position and where the grip holds the object in it: its place in the hand when it
    was grabbed, not where it has swung to (the grip's constraint is stiff, not rigid: a parcel carried
    ten metres hung 5 cm off, which took a shelf the arm reaches with it out of reach)."""
    assert sim.grasp is not None
    c = sim.client
    hand_pos, hand_orn = sim.robot.end_effector_pose()
    info = c.getConstraintInfo(sim.grasp.constraint)  # [6]: the pivot in the hand, [8]: its orientation
    obj_pos, _ = c.multiplyTransforms(hand_pos, hand_orn, info[6], info[8])
    return hand_pos, (obj_pos[0], obj_pos[1], obj_pos[2])


def put_down(sim: Sim, location: str, position: str) -> Reach:
    """Lower the held object onto the place position, let it go upright, and see where it comes to rest."""
    assert sim.grasp is not None, "put_down needs an object in the hand"
    c, robot, spec = sim.client, sim.robot, sim.robot_spec
    held = sim.grasp.name
    obj, pos = sim.objects[held], sim.positions[(location, position)]
    drop_z = pos.surface_z + obj.bottom + spec.place_clearance
    cx, cy = sim.center(pos)
    # Whether the arm reaches is a question about the grip (as the reach survey asks it), not about
    # how far the object swung on the way; the hand then moves the object as it hangs now.
    hand, (gx, gy, gz) = held_where_gripped(sim)
    _, err = robot.solve_ik((cx + hand[0] - gx, cy + hand[1] - gy, drop_z + hand[2] - gz))
    if err > spec.grasp_threshold:
        return Reach(ok=False, failure="unreachable", gap_m=err)
    (ox, oy, oz), _ = c.getBasePositionAndOrientation(obj.body)
    target_hand = (cx + hand[0] - ox, cy + hand[1] - oy, drop_z + hand[2] - oz)
    approach = approach_point(sim, target_hand)
    if _in_drawer(sim, pos):  # over the drawer's front, not through it: down into the tray from above
        approach = (target_hand[0], target_hand[1], target_hand[2] + DRAWER_LIFT)
    move_arm(sim, robot.solve_ik(approach)[0])
    move_hand_straight(sim, approach, target_hand)
    yaw = c.getEulerFromQuaternion(c.getBasePositionAndOrientation(obj.body)[1])[2]
    release(sim)
    # The hand has no fingers: the object is let go upright just above the surface.
    sim.put_on(obj, pos, yaw, xy=(cx, cy))
    move_hand_straight(sim, target_hand, approach)
    move_arm(sim, list(spec.arm.rest_pose))
    sim.settle([obj.body])
    where = truth.placement(sim, held)
    if where.state == "on_position" and (where.location, where.position) == (location, position):
        return Reach(ok=True, placement=where)
    return Reach(ok=False, failure="landed_elsewhere", placement=where)
