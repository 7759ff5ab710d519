"""Opening and closing a container: the arm goes to the handle and the joint's motor drives it, within
its force limit, while the hand follows the handle; physics decides how far it went.

Like `robocog.server.world.actions`, this assumes the tool checked the preconditions (the robot at the
container's location, the hand free) and reports only what happened, as an `Operation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from robocog.server.world import actions, containers
from robocog.server.world.sim import Sim

#: The joint counts as at its target within this (metres for a drawer, radians for a door).
AT_TARGET_M = 0.01
AT_TARGET_RAD = 0.03
#: The joint has stalled (something is in the way) when it gains less than this in `STALL_STEPS`.
STALL_PROGRESS = 0.002
STALL_STEPS = 60
#: The hand is moved to the handle again every this many steps while the joint moves.
FOLLOW_EVERY = 8


@dataclass(frozen=True)
class Operation:
    """How an open or close ended: "done" (the joint reached its target), "blocked" (it stalled short
    of it; the motor then holds it where it stopped) or "unreachable" (the arm cannot get to the handle;
    nothing moved). Joint positions in metres (a drawer) or radians (a door)."""

    outcome: Literal["done", "blocked", "unreachable"]
    start: float
    end: float
    target: float
    steps: int
    gap_m: float = 0.0  # the IK error for "unreachable"


def operate(sim: Sim, name: str, opened: bool) -> Operation:
    """Open (`opened`) or close the container `name` from where the robot stands."""
    robot, spec = sim.robot, sim.robot_spec
    box = sim.containers[name]
    g = box.geometry
    first_step = sim.steps
    start = sim.joint(name)
    target = g.open_q if opened else 0.0
    grip = containers.handle(sim, name)
    _, err = robot.solve_ik(grip)
    if err > spec.grasp_threshold:
        return Operation("unreachable", start, start, target, 0, gap_m=err)
    approach = actions.approach_point(sim, grip)
    actions.move_arm(sim, robot.solve_ik(approach)[0])
    actions.move_hand_straight(sim, approach, grip)
    for obj in sim.objects.values():  # what rests inside moves with the drawer, or falls when the door opens
        sim.wake(obj.body)
    containers.hold(sim.client, box, target)
    tolerance = AT_TARGET_M if g.joint == "prismatic" else AT_TARGET_RAD
    dt = sim.scene.physics.time_step
    budget = math.ceil(abs(target - start) / containers.speed(g) / dt * 2) + 2 * STALL_STEPS
    best, since_best = abs(target - start), 0
    for i in range(1, budget + 1):
        sim.step()
        left = abs(target - sim.joint(name))
        if left <= tolerance:
            break
        if best - left > STALL_PROGRESS:
            best, since_best = left, 0
        else:
            since_best += 1
            if since_best >= STALL_STEPS:
                break
        if i % FOLLOW_EVERY == 0:
            q, miss = robot.solve_ik(containers.handle(sim, name))
            if miss <= spec.grasp_threshold:
                robot.set_joints(q)
    end = sim.joint(name)
    done = abs(target - end) <= tolerance
    if not done:
        containers.hold(sim.client, box, end)  # stop pushing; hold it where physics left it
    actions.move_arm(sim, list(spec.arm.rest_pose))
    sim.settle()
    return Operation("done" if done else "blocked", start, sim.joint(name), target, sim.steps - first_step)
