"""The robot description as data: a pydantic schema for `assets/robot/*.yaml` and its loader.

A robot is a square omnidirectional base with an arm (a pybullet_data URDF) on top. Loading the
description also checks the arm's URDF against it: the file exists, the joints named continuous are
revolute joints of it, and the rest and carry poses give an angle for each movable joint.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import pybullet_data
from pydantic import BaseModel, Field

from robocog.assets import ASSETS_DIR
from robocog.shared import scene_bounds as bounds
from robocog.shared.config_files import STRICT_CONFIG, Rgba, inside, load_yaml_model
from robocog.shared.errors import ConfigError
from robocog.shared.scene_bounds import SCENE_FILE_BYTES


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


#: The largest URDF a robot description may name, bytes (the iiwa's is about 8 KB).
URDF_BYTES = 1024 * 1024


def revolute_joint_pattern(joint: str) -> str:
    """A regex matching a URDF's revolute joint `joint` up to its type (group 1), for unlimiting it."""
    return rf'(<joint\s+name="{re.escape(joint)}"\s+type=)"revolute"'


class _Strict(BaseModel):
    model_config = STRICT_CONFIG


class ArmSpec(_Strict):
    """The arm: a pybullet_data URDF mounted on top of the base."""

    urdf: str = Field(description="path inside pybullet_data")
    end_effector_link: int = Field(ge=0, lt=bounds.MAX_JOINTS)
    continuous_joints: list[str] = Field(
        default=[], description="joint names whose rotation limits are removed (made continuous)"
    )
    rest_pose: list[bounds.Angle] = Field(max_length=bounds.MAX_JOINTS, description="joint angles when idle")
    carry_pose: list[bounds.Angle] = Field(
        max_length=bounds.MAX_JOINTS, description="joint angles while driving, holding an object above the base"
    )
    joint_speed: float = Field(
        default=3.0,
        ge=bounds.JOINT_SPEED[0],
        le=bounds.JOINT_SPEED[1],
        description="rad/s of the fastest joint in a motion",
    )


class RobotSpec(_Strict):
    """A mobile manipulator: a square omnidirectional base with an arm on top."""

    name: str
    base_size: tuple[bounds.BaseExtent, bounds.BaseExtent, bounds.BaseExtent] = (0.5, 0.5, 0.3)
    base_color: Rgba = (0.3, 0.3, 0.35, 1.0)
    base_speed: float = Field(
        default=2.5,
        ge=bounds.BASE_SPEED[0],
        le=bounds.BASE_SPEED[1],
        description="m/s along the navigation path (simulated time)",
    )
    arm: ArmSpec
    grasp_threshold: float = Field(
        default=0.06,
        gt=0,
        le=bounds.GRASP_M,
        description="metres: the end effector must come this close to the grasp point",
    )
    grasp_clearance: float = Field(
        default=0.01,
        ge=-bounds.GRASP_M,
        le=bounds.GRASP_M,
        description="metres above an object's top to aim the hand at",
    )
    place_clearance: float = Field(
        default=0.005,
        ge=-bounds.GRASP_M,
        le=bounds.GRASP_M,
        description="metres above the surface to release an object",
    )


def shipped_folders() -> tuple[Path, Path]:
    """Where robocog's own files lie: its assets and pybullet_data (the URDFs a scene may name)."""
    return ASSETS_DIR, Path(pybullet_data.getDataPath())


def outside_problem(name: str, path: Path, folders: Sequence[Path]) -> str | None:
    """Why the file `name` (found at `path`) may not be read, when it lies outside `folders` (links followed)."""
    if inside(path, folders):
        return None
    return f"{name!r} lies outside {' and '.join(str(f) for f in folders)}: a scene names files only there"


def load_robot(path: Path, folders: Sequence[Path] = ()) -> RobotSpec:
    """Load and validate a robot description file, and check its arm's URDF against it: the URDF lies in
    the robot file's folder, robocog's assets, pybullet_data or one of `folders` (a scene's own)."""
    spec = load_yaml_model(path, RobotSpec, max_bytes=SCENE_FILE_BYTES)
    problem = urdf_problem(spec.arm.urdf)
    if problem is not None:
        raise ConfigError(f"{path}: arm.urdf: {problem}")
    urdf = resolve_urdf(spec.arm.urdf)
    problem = outside_problem(spec.arm.urdf, urdf, (path.parent, *shipped_folders(), *folders))
    if problem is not None:
        raise ConfigError(f"{path}: arm.urdf: {problem}")
    if urdf.stat().st_size > URDF_BYTES:
        raise ConfigError(f"{path}: arm.urdf: {spec.arm.urdf!r} is larger than {URDF_BYTES:,} bytes")
    try:
        text = urdf.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: arm.urdf: {spec.arm.urdf!r} cannot be read: {exc}") from exc
    for joint in spec.arm.continuous_joints:
        if re.search(revolute_joint_pattern(joint), text) is None:
            raise ConfigError(f"{path}: arm.continuous_joints: {spec.arm.urdf} has no revolute joint {joint!r}")
    movable = len(re.findall(r'<joint\s[^>]*type="(?:revolute|continuous|prismatic)"', text))
    links = len(re.findall(r"<joint\s", text))
    if spec.arm.end_effector_link >= links:
        raise ConfigError(
            f"{path}: arm.end_effector_link: {spec.arm.end_effector_link}, but {spec.arm.urdf} has links 0 to "
            f"{links - 1}"
        )
    for field in ("rest_pose", "carry_pose"):
        given = len(getattr(spec.arm, field))
        if given != movable:
            raise ConfigError(f"{path}: arm.{field}: {given} joint angles, but {spec.arm.urdf} has {movable} joints")
    return spec
