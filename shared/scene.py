"""The scene as data: a pydantic schema for `assets/scenes/*.yaml` and its loader.

A scene names rooms, walls, semantic locations joined by edges, furniture built from boxes,
place positions (regions on a support surface where objects may rest) and the movable objects
with their start state. Users add a location or an object by editing YAML; a malformed file
raises `ConfigError` naming the file, the field and the problem on one line
(`scene.yaml: edges[7]: 'Attic' is not a location`). Loading a scene also checks the files it
refers to (the robot description, its arm's URDF, objects' URDFs) where the world will look for them.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

import pybullet_data
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import ErrorDetails

from robocog.assets import ASSETS_DIR
from robocog.shared.errors import ConfigError

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Rgba = tuple[float, float, float, float]
Positive = Annotated[float, Field(gt=0)]
M = TypeVar("M", bound=BaseModel)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Room(_Strict):
    """A rectangular floor area, used for rendering and for naming where things are."""

    name: str
    x: Vec2 = Field(description="min and max x of the floor area, metres")
    y: Vec2 = Field(description="min and max y of the floor area, metres")
    color: Rgba = (0.85, 0.85, 0.8, 1.0)


class Wall(_Strict):
    """A straight wall segment from `start` to `end` (leave gaps between segments for doors)."""

    start: Vec2
    end: Vec2
    thickness: Positive = 0.1
    height: Positive = 1.2


class Location(_Strict):
    """A semantic location: a named point on the navigation graph where the robot can stand."""

    name: str
    x: float
    y: float


class Box(_Strict):
    """A box-shaped part of a piece of furniture; `center` is its centre in world coordinates."""

    name: str
    size: Vec3 = Field(description="full extents x, y, z in metres")
    center: Vec3
    color: Rgba = (0.55, 0.4, 0.25, 1.0)

    @model_validator(mode="after")
    def _positive(self) -> Box:
        if min(self.size) <= 0:
            raise ValueError("size: must be positive in x, y and z")
        return self


class Furniture(_Strict):
    """Static furniture made of boxes (a shelf's layers, a table's top and legs)."""

    name: str
    parts: list[Box] = Field(min_length=1)


class PlacePosition(_Strict):
    """A region on a support surface at a location where one object may rest."""

    location: str
    name: str = Field(description="the position's name within its location, e.g. 'top' or 'floor'")
    center: Vec2
    size: Vec2 = Field(description="extent of the region in x and y, metres")
    support: str = Field(description="'floor' or 'FURNITURE/PART', the surface an object rests on")


class ObjectStart(_Strict):
    """Where an object starts: on a place position, or at an explicit pose (e.g. a TV on its table)."""

    location: str | None = None
    position: str | None = None
    pose: Vec3 | None = None
    yaw: float = 0.0

    @model_validator(mode="after")
    def _one_kind(self) -> ObjectStart:
        on_position = self.location is not None and self.position is not None
        if on_position == (self.pose is not None):
            raise ValueError("give either location and position, or pose")
        return self


class SceneObject(_Strict):
    """A movable object. Primitive shapes are built from `size`; `urdf` loads a pybullet_data model."""

    name: str
    shape: Literal["box", "cylinder", "urdf"] = "box"
    size: Vec3 = Field(description="bounding extents x, y, z in metres (for a cylinder: diameter, diameter, height)")
    urdf: str | None = Field(default=None, description="path inside pybullet_data, e.g. objects/mug.urdf")
    urdf_scale: Positive = 1.0
    mass: Positive = 0.2
    color: Rgba = (0.8, 0.2, 0.2, 1.0)
    graspable: bool = True
    start: ObjectStart

    @model_validator(mode="after")
    def _urdf_given(self) -> SceneObject:
        if (self.shape == "urdf") != (self.urdf is not None):
            raise ValueError("urdf: shape 'urdf' needs a urdf path, and a urdf path needs shape 'urdf'")
        if min(self.size) <= 0:
            raise ValueError("size: must be positive in x, y and z")
        return self


class Physics(_Strict):
    """Simulation settings."""

    time_step: Positive = 1.0 / 120.0
    gravity: float = -9.81
    solver_iterations: int = Field(default=50, ge=1)
    settle_steps: int = Field(default=120, ge=1, description="most steps a released object may take to rest")
    rest_speed: Positive = Field(default=0.02, description="m/s under which an object counts as resting")


class Scene(_Strict):
    """A whole household scene."""

    name: str
    robot: str = Field(default="robot/iiwa_mobile.yaml", description="robot description, relative to assets/")
    robot_start: str = Field(description="the location where the robot starts")
    physics: Physics = Physics()
    rooms: list[Room] = []
    walls: list[Wall] = []
    locations: list[Location] = Field(min_length=1)
    edges: list[tuple[str, str]] = []
    furniture: list[Furniture] = []
    place_positions: list[PlacePosition] = []
    objects: list[SceneObject] = []
    location_radius: Positive = Field(
        default=1.3, description="how far from a location an object may lie and still be seen as 'at' it"
    )

    @model_validator(mode="after")
    def _consistent(self) -> Scene:
        names = [loc.name for loc in self.locations]
        _unique("locations", names)
        _unique("objects", [o.name for o in self.objects])
        _unique("furniture", [f.name for f in self.furniture])
        known = set(names)
        if self.robot_start not in known:
            raise ValueError(f"robot_start: {self.robot_start!r} is not a location (known: {sorted(known)})")
        for i, (a, b) in enumerate(self.edges):
            for end in (a, b):
                if end not in known:
                    raise ValueError(f"edges[{i}]: {end!r} is not a location")
        parts = {f"{f.name}/{p.name}" for f in self.furniture for p in f.parts}
        seen: set[tuple[str, str]] = set()
        for i, pos in enumerate(self.place_positions):
            if pos.location not in known:
                raise ValueError(f"place_positions[{i}]: location {pos.location!r} is not a location")
            if pos.support != "floor" and pos.support not in parts:
                raise ValueError(
                    f"place_positions[{i}]: support {pos.support!r} is neither 'floor' nor a furniture part "
                    f"(known parts: {sorted(parts)})"
                )
            key = (pos.location, pos.name)
            if key in seen:
                raise ValueError(f"place_positions[{i}]: {pos.location} / {pos.name} is defined twice")
            seen.add(key)
        taken: dict[tuple[str, str | None], str] = {}
        for i, obj in enumerate(self.objects):
            start = obj.start
            if start.location is None:
                continue
            spot = (start.location, start.position)
            if spot not in seen:
                raise ValueError(
                    f"objects[{i}] ({obj.name}): start position {start.location} / {start.position} "
                    "is not a place position"
                )
            if spot in taken:
                raise ValueError(
                    f"objects[{i}] ({obj.name}): start position {start.location} / {start.position} "
                    f"is already taken by {taken[spot]}"
                )
            taken[spot] = obj.name
        return self

    def robot_file(self) -> Path:
        """The robot description this scene names (relative paths are inside assets/)."""
        return ASSETS_DIR / self.robot

    def location(self, name: str) -> Location:
        """The location called `name` (exact)."""
        for loc in self.locations:
            if loc.name == name:
                return loc
        raise KeyError(name)


def _unique(what: str, names: list[str]) -> None:
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ValueError(f"{what}: duplicate names {dupes}")


#: Most pydantic problems one error line lists before "and N more".
_MAX_PROBLEMS = 3
# A model validator's message that starts with the field it is about: "edges[7]: ..." or
# "objects[0] (cube): ...".
_FIELD_FIRST = re.compile(r"^[A-Za-z_]\w*(\[\d+\])*(\.[A-Za-z_]\w*(\[\d+\])*)*( \([^()]*\))?: ")


def field_path(loc: tuple[int | str, ...]) -> str:
    """A pydantic location as the file's field: ("edges", 7, "x") -> "edges[7].x"."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else f".{part}" if out else str(part)
    return out


def _problem(err: ErrorDetails) -> str:
    """One pydantic error as "field: problem"; a model validator's "field: problem" keeps its field."""
    where = field_path(err["loc"])
    msg = err["msg"]
    if err["type"] == "value_error":
        msg = msg.removeprefix("Value error, ")
        if _FIELD_FIRST.match(msg):
            return f"{where}.{msg}" if where else msg
    return f"{where}: {msg}" if where else msg


def validation_problems(exc: ValidationError) -> str:
    """A pydantic `ValidationError` as one line: "field: problem; field: problem"."""
    problems = [_problem(err) for err in exc.errors()]
    more = len(problems) - _MAX_PROBLEMS
    return "; ".join(problems[:_MAX_PROBLEMS]) + (f"; and {more} more" if more > 0 else "")


def _non_finite(data: Any, where: str = "") -> str | None:
    """The field of the first NaN or infinite number in YAML data (`.nan`, `.inf`), if any."""
    seen: set[int] = set()  # YAML aliases share nodes: visit each container once
    stack: list[tuple[Any, str]] = [(data, where)]
    while stack:
        node, at = stack.pop()
        if isinstance(node, float) and not math.isfinite(node):
            return at
        if isinstance(node, dict | list) and id(node) not in seen:
            seen.add(id(node))
            items = node.items() if isinstance(node, dict) else enumerate(node)
            children = [(v, f"{at}[{k}]" if isinstance(k, int) else f"{at}.{k}" if at else str(k)) for k, v in items]
            stack.extend(reversed(children))
    return None


def read_yaml(path: Path) -> Any:
    """The YAML data of `path`; `ConfigError` (one line: file, where, problem) when it cannot be read."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError as exc:
        raise ConfigError(f"{path}: file not found") from exc
    except IsADirectoryError as exc:
        raise ConfigError(f"{path}: is a directory, not a file") from exc
    except OSError as exc:
        raise ConfigError(f"{path}: cannot be read: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"{path}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x}); save the file as UTF-8"
        ) from exc
    try:
        return yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = exc.problem or exc.context or "syntax error"
        raise ConfigError(f"{path}: {where}not valid YAML: {problem}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from exc
    except RecursionError as exc:
        raise ConfigError(f"{path}: not valid YAML: nested too deeply") from exc


def load_yaml_model(path: Path, model: type[M]) -> M:
    """Read `path` as YAML and validate it as `model`; errors name the file, the field and the problem.

    Every error is one line, `FILE: FIELD: problem` (`FILE: line L, column C: ...` for YAML syntax).
    """
    data = read_yaml(path)
    if not isinstance(data, dict):
        got = "an empty file" if data is None else f"a {type(data).__name__}"
        raise ConfigError(f"{path}: expected a mapping of fields (name: value), got {got}")
    bad = _non_finite(data)
    if bad is not None:
        raise ConfigError(f"{path}: {bad}: must be a finite number, not NaN or infinity")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"{path}: {validation_problems(exc)}") from exc


def resolve_urdf(urdf: str) -> Path:
    """Where a URDF named in a scene or robot file lives: absolute, or a path inside pybullet_data.

    The validator and the world builder both find URDFs through this one function.
    """
    path = Path(urdf)
    return path if path.is_absolute() else Path(pybullet_data.getDataPath()) / path


def _urdf_problem(urdf: str) -> str | None:
    path = resolve_urdf(urdf)
    if path.is_file():
        return None
    inside = "" if Path(urdf).is_absolute() else f" in pybullet_data ({pybullet_data.getDataPath()})"
    return f"{urdf!r}: no such file{inside}"


def revolute_joint_pattern(joint: str) -> str:
    """A regex matching a URDF's revolute joint `joint` up to its type (group 1), for unlimiting it."""
    return rf'(<joint\s+name="{re.escape(joint)}"\s+type=)"revolute"'


def load_scene(path: Path) -> Scene:
    """Load and validate a scene file, and the robot description and URDFs it refers to."""
    scene = load_yaml_model(path, Scene)
    robot = scene.robot_file()
    if not robot.is_file():
        raise ConfigError(f"{path}: robot: {scene.robot!r}: no such file (robot files are relative to {ASSETS_DIR})")
    load_robot(robot)
    for i, obj in enumerate(scene.objects):
        problem = _urdf_problem(obj.urdf) if obj.urdf is not None else None
        if problem is not None:
            raise ConfigError(f"{path}: objects[{i}].urdf: {problem}")
    return scene


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
    problem = _urdf_problem(spec.arm.urdf)
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
