"""The scene as data: a pydantic schema for `assets/scenes/*.yaml` and its loader.

A scene names rooms, walls, semantic locations joined by edges, furniture built from boxes,
place positions (regions on a support surface where objects may rest) and the movable objects
with their start state. Users add a location or an object by editing YAML; a malformed file
raises `ConfigError` naming the file, the field and the problem on one line
(`scene.yaml: edges[7]: 'Attic' is not a location`). Loading a scene also checks the files it
refers to (the robot description, its arm's URDF, objects' URDFs) where the world will look for them.

Objects may carry `descriptions`, the referring expressions a task names them by ("drinking vessel");
`Scene.described_as` finds the objects a text refers to. A shipped scene is named by its file's stem
(`scene_path("flat")`), and `layout_problems` checks the geometry the schema cannot see (a connected
map, nothing overlapping, positions on their supports and within reach); every shipped scene passes it.
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
from robocog.shared.limits import NAME_CHARS

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


#: One referring expression: words, no line breaks, at most a name's length.
Description = Annotated[str, Field(min_length=1, max_length=NAME_CHARS, pattern=r"^[^\r\n]*\S[^\r\n]*$")]
_ARTICLE = re.compile(r"^(?:the|an?)(?:\s+|$)", re.IGNORECASE)


def referring_key(text: str) -> str:
    """How a name or description is compared: lower case, spaces collapsed, a leading article dropped
    ("The  Drinking vessel" -> "drinking vessel")."""
    return _ARTICLE.sub("", " ".join(text.split()).lower())


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
    descriptions: list[Description] = Field(
        default=[],
        description="referring expressions a task may name the object by, e.g. 'drinking vessel' for a mug",
    )

    @model_validator(mode="after")
    def _urdf_given(self) -> SceneObject:
        if (self.shape == "urdf") != (self.urdf is not None):
            raise ValueError("urdf: shape 'urdf' needs a urdf path, and a urdf path needs shape 'urdf'")
        if min(self.size) <= 0:
            raise ValueError("size: must be positive in x, y and z")
        seen: set[str] = set()
        for i, text in enumerate(self.descriptions):
            key = referring_key(text)
            if not key:
                raise ValueError(f"descriptions[{i}]: {text!r} says nothing once its article is dropped")
            if key == referring_key(self.name):
                raise ValueError(f"descriptions[{i}]: {text!r} is the object's own name")
            if key in seen:
                raise ValueError(f"descriptions[{i}]: {text!r} is given twice")
            seen.add(key)
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
        named = {referring_key(o.name): o.name for o in self.objects}
        for i, obj in enumerate(self.objects):
            for j, text in enumerate(obj.descriptions):
                other = named.get(referring_key(text))
                if other is not None:
                    raise ValueError(f"objects[{i}].descriptions[{j}] ({obj.name}): {text!r} names the {other}")
        return self

    def robot_file(self) -> Path:
        """The robot description this scene names (relative paths are inside assets/)."""
        return ASSETS_DIR / self.robot

    def described_as(self, text: str) -> list[str]:
        """The objects (scene order) that `text` refers to: by name or by one of their descriptions,
        compared without case, extra spaces or a leading article. Several when the text is ambiguous."""
        key = referring_key(text)
        return [o.name for o in self.objects if key in {referring_key(o.name), *map(referring_key, o.descriptions)}]

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


#: Where the shipped scenes live; a scene is named by its file's stem.
SCENES_DIR = ASSETS_DIR / "scenes"


def scene_names() -> list[str]:
    """The shipped scenes' names, sorted."""
    return sorted(p.stem for p in SCENES_DIR.glob("*.yaml"))


def scene_path(scene: str | Path) -> Path:
    """The file of a scene given by name ('flat' -> assets/scenes/flat.yaml) or by path (kept as it is).

    A bare word (no directory, no suffix) that is not an existing file is a name; an unknown name is
    a `ConfigError` listing the known ones. A path is returned unchanged (`load_scene` checks it).
    """
    path = Path(scene)
    text = str(scene)
    if path.is_file() or path.suffix or "/" in text or "\\" in text:
        return path
    named = SCENES_DIR / f"{text}.yaml"
    if named.is_file():
        return named
    raise ConfigError(
        f"scene {text!r}: no such scene; known scenes: {', '.join(scene_names())} (or give the path of a scene YAML)"
    )


#: Metres from a location to the centre of one of its place positions that the arm reaches (the
#: shipped scenes keep 0.6 to 0.67; the physics decides, this only catches a position put far off).
REACH_M = 0.7
#: Half the width of the robot's base: a location closer than this to a wall or furniture is cramped.
BASE_HALF_M = 0.25
_Rect = tuple[float, float, float, float]  # x0, y0, x1, y1


def _rect(center: tuple[float, ...], size: tuple[float, ...]) -> _Rect:
    return (center[0] - size[0] / 2, center[1] - size[1] / 2, center[0] + size[0] / 2, center[1] + size[1] / 2)


def _overlap(a: _Rect, b: _Rect, slack: float = 1e-6) -> bool:
    """Whether two rectangles overlap by more than `slack` in x and in y (touching is not overlapping)."""
    return min(a[2], b[2]) - max(a[0], b[0]) > slack and min(a[3], b[3]) - max(a[1], b[1]) > slack


def _point_segment(px: float, py: float, a: Vec2, b: Vec2) -> float:
    (ax, ay), (bx, by) = a, b
    dx, dy = bx - ax, by - ay
    t = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(px - (ax + t * dx), py - (ay + t * dy))


def _rect_wall_gap(r: _Rect, wall: Wall) -> float:
    """Distance from a rectangle to a wall's surface in the plan (negative or zero when they meet)."""
    x0, y0, x1, y1 = r
    a, b = wall.start, wall.end
    inside = any(x0 <= px <= x1 and y0 <= py <= y1 for px, py in (a, b))
    if not inside:
        # The segment crosses the rectangle when it crosses a diagonal's line within both.
        for (cx, cy), (ex, ey) in (((x0, y0), (x1, y1)), ((x0, y1), (x1, y0))):
            d1 = (b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0])
            d2 = (b[0] - a[0]) * (ey - a[1]) - (b[1] - a[1]) * (ex - a[0])
            d3 = (ex - cx) * (a[1] - cy) - (ey - cy) * (a[0] - cx)
            d4 = (ex - cx) * (b[1] - cy) - (ey - cy) * (b[0] - cx)
            if d1 * d2 < 0 and d3 * d4 < 0:
                inside = True
    if inside:
        return -wall.thickness / 2
    corners = [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]
    gap = min(_point_segment(px, py, a, b) for px, py in corners)
    for px, py in (a, b):
        gap = min(gap, math.hypot(max(x0 - px, 0.0, px - x1), max(y0 - py, 0.0, py - y1)))
    return gap - wall.thickness / 2


def layout_problems(scene: Scene) -> list[str]:
    """What is physically wrong with a scene's layout, one line each (none for a sound scene).

    The schema checks names and references; this checks the geometry a world needs: every location
    reachable from the robot's start over the edges, inside a room and clear of walls and furniture;
    no two pieces of furniture, nor furniture and a wall, overlapping; each place position on its
    support (a furniture part's top, or free floor), within the arm's reach of its location, and
    apart from the other positions on the same surface.
    """
    problems: list[str] = []
    # The navigation graph is connected.
    neighbours: dict[str, set[str]] = {loc.name: set() for loc in scene.locations}
    for a, b in scene.edges:
        neighbours[a].add(b)
        neighbours[b].add(a)
    seen, todo = {scene.robot_start}, [scene.robot_start]
    while todo:
        for nxt in neighbours[todo.pop()] - seen:
            seen.add(nxt)
            todo.append(nxt)
    cut_off = [loc.name for loc in scene.locations if loc.name not in seen]
    if cut_off:
        problems.append(f"locations {cut_off} cannot be reached from {scene.robot_start!r} over the edges")
    boxes = [(f"{f.name}/{p.name}", f.name, p) for f in scene.furniture for p in f.parts]
    footprints = {key: _rect(p.center, p.size) for key, _, p in boxes}
    # Furniture against furniture and walls.
    for i, (key, owner, _) in enumerate(boxes):
        for other, other_owner, _ in boxes[i + 1 :]:
            if owner != other_owner and _overlap(footprints[key], footprints[other]):
                problems.append(f"furniture {key} overlaps {other}")
        for j, wall in enumerate(scene.walls):
            if _rect_wall_gap(footprints[key], wall) < -1e-6:
                problems.append(f"furniture {key} overlaps walls[{j}]")
    # Locations: in a room, clear of walls and furniture.
    for loc in scene.locations:
        if scene.rooms and not any(r.x[0] <= loc.x <= r.x[1] and r.y[0] <= loc.y <= r.y[1] for r in scene.rooms):
            problems.append(f"location {loc.name!r} is in no room")
        base = _rect((loc.x, loc.y), (2 * BASE_HALF_M, 2 * BASE_HALF_M))
        for j, wall in enumerate(scene.walls):
            if _rect_wall_gap(base, wall) < -1e-6:
                problems.append(f"location {loc.name!r}: the robot would stand in walls[{j}]")
        for key, _, _ in boxes:
            if _overlap(base, footprints[key]):
                problems.append(f"location {loc.name!r}: the robot would stand in furniture {key}")
    # Place positions: on their support, in reach, apart.
    for i, pos in enumerate(scene.place_positions):
        label = f"place position {pos.location} / {pos.name}"
        region = _rect(pos.center, pos.size)
        loc = scene.location(pos.location)
        far = math.hypot(pos.center[0] - loc.x, pos.center[1] - loc.y)
        if far > REACH_M:
            problems.append(f"{label}: {far:.2f} m from its location, past the arm's reach ({REACH_M} m)")
        if pos.support == "floor":
            for key, _, _ in boxes:
                if _overlap(region, footprints[key]):
                    problems.append(f"{label}: the floor there is under furniture {key}")
            for j, wall in enumerate(scene.walls):
                if _rect_wall_gap(region, wall) < -1e-6:
                    problems.append(f"{label}: overlaps walls[{j}]")
        else:
            x0, y0, x1, y1 = footprints[pos.support]
            if not (x0 <= pos.center[0] <= x1 and y0 <= pos.center[1] <= y1):
                problems.append(f"{label}: its centre is not over {pos.support}")
        for later in scene.place_positions[i + 1 :]:
            if later.support == pos.support and _overlap(region, _rect(later.center, later.size)):
                problems.append(f"{label} overlaps {later.location} / {later.name} on {pos.support}")
    return problems


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
