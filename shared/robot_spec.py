"""The robot description as data: a pydantic schema for `assets/robot/*.yaml` and its loader.

A robot is a square omnidirectional base with an arm (a pybullet_data URDF) on top. Loading the
description also checks the arm's URDF against it: the file exists, the joints named continuous are
revolute joints of it, and the rest and carry poses give an angle for each movable joint.
"""

from __future__ import annotations

import re
from pathlib import Path

import pybullet_data
from pydantic import BaseModel, Field

from robocog.shared.config_files import STRICT_CONFIG, Positive, Rgba, Vec3, load_yaml_model
from robocog.shared.errors import ConfigError


def resolve_urdf(urdf: str) -> Path:
    """Where a URDF named in a scene or robot file lives: absolute, or a path inside pybullet_data.

    The validator and the world builder both find URDFs through this one function.
    """
    path = Path(urdf)
    return path if path.is_absolute() else Path(pybullet_data.getDataPath()) / path


def urdf_problem(urdf: str) -> str | None:
    """What is wrong with a URDF named in a scene or robot file (no such file), or None."""
    path = resolve_urdf(urdf)
    if path.is_file():
        return None
    inside = "" if Path(urdf).is_absolute() else f" in pybullet_data ({pybullet_data.getDataPath()})"
    return f"{urdf!r}: no such file{inside}"


def revolute_joint_pattern(joint: str) -> str:
    """A regex matching a URDF's revolute joint `joint` up to its type (group 1), for unlimiting it."""
    return rf'(<joint\s+name="{re.escape(joint)}"\s+type=)"revolute"'


class _Strict(BaseModel):
    model_config = STRICT_CONFIG


class ArmSpec(_Strict):
    """The arm: a pybullet_data URDF mounted on top of the base."""

    urdf: str = Field(description="path inside pybullet_data")
    end_effector_link: int = Field(ge=0)
    continuous_joints: list[str] = Field(
        default=[], description="joint names whose rotation limits are removed (made continuous)"
    )
    rest_pose: list[float] = Field(description="joint angles when idle")
    carry_pose: list[float] = Field(description="joint angles while driving, holding an object above the base")
    joint_speed: Positive = Field(default=3.0, description="rad/s of the fastest joint in a motion")


class RobotSpec(_Strict):
    """A mobile manipulator: a square omnidirectional base with an arm on top."""

    name: str
    base_size: Vec3 = (0.5, 0.5, 0.3)
    base_color: Rgba = (0.3, 0.3, 0.35, 1.0)
    base_speed: Positive = Field(default=2.5, description="m/s along the navigation path (simulated time)")
    arm: ArmSpec
    grasp_threshold: Positive = Field(
        default=0.06, description="metres: the end effector must come this close to the grasp point"
    )
    grasp_clearance: float = Field(default=0.01, description="metres above an object's top to aim the hand at")
    place_clearance: float = Field(default=0.005, description="metres above the surface to release an object")


def load_robot(path: Path) -> RobotSpec:
    """Load and validate a robot description file, and check its arm's URDF against it."""
    spec = load_yaml_model(path, RobotSpec)
    problem = urdf_problem(spec.arm.urdf)
    if problem is not None:
        raise ConfigError(f"{path}: arm.urdf: {problem}")
    urdf = resolve_urdf(spec.arm.urdf)
    try:
        text = urdf.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: arm.urdf: {spec.arm.urdf!r} cannot be read: {exc}") from exc
    for joint in spec.arm.continuous_joints:
        if re.search(revolute_joint_pattern(joint), text) is None:
            raise ConfigError(f"{path}: arm.continuous_joints: {spec.arm.urdf} has no revolute joint {joint!r}")
    movable = len(re.findall(r'<joint\s[^>]*type="(?:revolute|continuous|prismatic)"', text))
    for field in ("rest_pose", "carry_pose"):
        given = len(getattr(spec.arm, field))
        if given != movable:
            raise ConfigError(f"{path}: arm.{field}: {given} joint angles, but {spec.arm.urdf} has {movable} joints")
    return spec
