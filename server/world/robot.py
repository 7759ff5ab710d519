"""The mobile manipulator: a square omnidirectional base with pybullet_data's KUKA iiwa on top.

The base is a static box that the world drives kinematically along navigation paths (x, y, yaw);
the arm is a fixed-base multibody mounted on it whose joints follow interpolated trajectories.
The arm's first joint is made continuous (no rotation limit), as in the paper, by deriving a copy
of the URDF at run time with that joint's type changed and the mesh paths made absolute.
"""

from __future__ import annotations

import functools
import hashlib
import math
import re
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world.arm_meshes import reduced_stl, write_once
from robocog.shared.robot_spec import RobotSpec, resolve_urdf, revolute_joint_pattern

Vec3 = tuple[float, float, float]


def derived_urdf(spec: RobotSpec) -> Path:
    """A copy of the arm's URDF with `continuous_joints` unlimited, absolute mesh paths and its STL
    collision meshes reduced to their extreme points (`arm_meshes`; cached)."""
    source = resolve_urdf(spec.arm.urdf)
    text = source.read_text(encoding="utf-8")
    text = re.sub(r'filename="(?!/)([^"]+)"', lambda m: f'filename="{(source.parent / m.group(1)).as_posix()}"', text)
    text = re.sub(r"<collision>.*?</collision>", _reduced_collision, text, flags=re.S)
    for joint in spec.arm.continuous_joints:
        text, count = re.subn(revolute_joint_pattern(joint), r'\1"continuous"', text)
        if count != 1:
            raise ValueError(f"{source}: no revolute joint named {joint!r} to make continuous")
        block = re.compile(rf'(<joint\s+name="{re.escape(joint)}".*?</joint>)', re.S)
        text = block.sub(lambda m: re.sub(r'\s(lower|upper)="[^"]*"', "", m.group(1)), text)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    return write_once(Path(tempfile.gettempdir()) / "robocog-urdf" / f"{source.stem}-{digest}.urdf", text.encode())


def _reduced_collision(block: re.Match[str]) -> str:
    return re.sub(
        r'filename="([^"]+)"', lambda m: f'filename="{reduced_stl(Path(m.group(1))).as_posix()}"', block.group(0)
    )


class Robot:
    """The robot's bodies in one PyBullet client, and its kinematics."""

    def __init__(self, client: BulletClient, spec: RobotSpec, x: float, y: float, yaw: float = 0.0) -> None:
        self.client = client
        self.spec = spec
        sx, sy, sz = spec.base_size
        col = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[sx / 2, sy / 2, sz / 2])
        vis = client.createVisualShape(
            pybullet.GEOM_BOX, halfExtents=[sx / 2, sy / 2, sz / 2], rgbaColor=spec.base_color
        )
        self.base = client.createMultiBody(0, col, vis, [x, y, sz / 2], useMaximalCoordinates=True)
        self.arm = client.loadURDF(
            str(derived_urdf(spec)), [x, y, sz], useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE
        )
        self.joints = [j for j in range(client.getNumJoints(self.arm)) if client.getJointInfo(self.arm, j)[2] != 4]
        self.ee = spec.arm.end_effector_link
        self._forces = [500.0] * len(self.joints)
        # The robot's bodies collide with nothing: the arm reaches kinematically through furniture, the
        # base only ever stops at locations (away from place positions), and a held object must not
        # fight the body carrying it.
        for link in range(-1, client.getNumJoints(self.arm)):
            client.setCollisionFilterGroupMask(self.arm, link, 0, 0)
        client.setCollisionFilterGroupMask(self.base, -1, 0, 0)
        cid = client._client
        self._reset_pose = functools.partial(pybullet.resetBasePositionAndOrientation, physicsClientId=cid)
        self._reset_joints = functools.partial(pybullet.resetJointStatesMultiDof, physicsClientId=cid)
        self._motors = functools.partial(pybullet.setJointMotorControlArray, physicsClientId=cid)
        self.x, self.y, self.yaw = x, y, yaw
        self.set_base(x, y, yaw)
        self.set_joints(spec.arm.rest_pose)

    # --- base ------------------------------------------------------------------------------------

    def set_base(self, x: float, y: float, yaw: float) -> None:
        """Teleport the base (and the arm on it) to (x, y, yaw)."""
        self.x, self.y, self.yaw = x, y, yaw
        quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        sz = self.spec.base_size[2]
        self._reset_pose(self.base, (x, y, sz / 2), quat)
        self._reset_pose(self.arm, (x, y, sz), quat)

    # --- arm -------------------------------------------------------------------------------------

    def joint_positions(self) -> list[float]:
        return [s[0] for s in self.client.getJointStates(self.arm, self.joints)]

    def set_joints(self, q: Sequence[float], velocities: Sequence[float] | None = None) -> None:
        """Put the arm at `q` now and have its motors hold it there."""
        vel = velocities if velocities is not None else [0.0] * len(q)
        self._reset_joints(self.arm, self.joints, [[v] for v in q], [[v] for v in vel])
        self._motors(self.arm, self.joints, pybullet.POSITION_CONTROL, targetPositions=list(q), forces=self._forces)

    def end_effector(self) -> Vec3:
        """World position of the end effector (forward kinematics of the current joints)."""
        state = self.client.getLinkState(self.arm, self.ee, computeForwardKinematics=True)
        return tuple(state[4])

    def end_effector_pose(self) -> tuple[Vec3, tuple[float, float, float, float]]:
        state = self.client.getLinkState(self.arm, self.ee, computeForwardKinematics=True)
        return tuple(state[4]), tuple(state[5])

    def solve_ik(self, target: Vec3) -> tuple[list[float], float]:
        """Joint angles that bring the end effector to `target`, and the remaining error in metres.

        The first joint is turned to face the target (it has no limit); inverse kinematics then
        solves the rest. The error is measured by forward kinematics, so an unreachable target
        shows up as a large error rather than an exception.
        """
        c = self.client
        saved = self.joint_positions()
        facing = math.atan2(target[1] - self.y, target[0] - self.x) - self.yaw
        seed = list(self.spec.arm.rest_pose)
        seed[0] = math.atan2(math.sin(facing), math.cos(facing))
        self.set_joints(seed)
        best: list[float] = seed
        best_err = math.inf
        for _ in range(4):  # re-solving from the last solution refines hard targets
            q = c.calculateInverseKinematics(
                self.arm, self.ee, list(target), maxNumIterations=200, residualThreshold=1e-5
            )
            q = [float(v) for v in q[: len(self.joints)]]
            self.set_joints(q)
            err = float(np.linalg.norm(np.subtract(self.end_effector(), target)))
            if err < best_err:
                best, best_err = q, err
            if err < 1e-3:
                break
        self.set_joints(saved)
        return best, best_err

    def joint_trajectory(self, q_to: Sequence[float], time_step: float) -> Iterator[tuple[list[float], list[float]]]:
        """Joint positions and velocities, one per physics step, moving linearly to `q_to`."""
        q_from = np.asarray(self.joint_positions())
        delta = np.asarray(q_to) - q_from
        steps = max(1, math.ceil(float(np.max(np.abs(delta))) / (self.spec.arm.joint_speed * time_step)))
        velocity = (delta / (steps * time_step)).tolist()
        for i in range(1, steps + 1):
            yield (q_from + delta * (i / steps)).tolist(), velocity if i < steps else [0.0] * len(velocity)
