"""The scene as data: a pydantic schema for `assets/scenes/*.yaml`.

A scene names rooms, walls, semantic locations joined by edges, furniture built from boxes,
place positions (regions on a support surface where objects may rest) and the movable objects
with their start state. Users add a location or an object by editing YAML; the schema checks names
and references (`robocog.shared.scene_files` loads a file, `robocog.shared.scene_layout` checks the
geometry the schema cannot see).

Objects may carry `descriptions`, the referring expressions a task names them by ("drinking vessel");
`Scene.described_as` finds the objects a text refers to.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, Field, model_validator

from robocog.assets import ASSETS_DIR
from robocog.shared import scene_bounds as bounds
from robocog.shared.config_files import STRICT_CONFIG, Rgba
from robocog.shared.limits import NAME_CHARS
from robocog.shared.names import name_key
from robocog.shared.perturbations import MAX_PERTURBATIONS, Perturbation


class _Strict(BaseModel):
    model_config = STRICT_CONFIG


class Room(_Strict):
    """A rectangular floor area, used for rendering and for naming where things are."""

    name: str
    x: bounds.Point2 = Field(description="min and max x of the floor area, metres")
    y: bounds.Point2 = Field(description="min and max y of the floor area, metres")
    color: Rgba = (0.85, 0.85, 0.8, 1.0)


class Wall(_Strict):
    """A straight wall segment from `start` to `end` (leave gaps between segments for doors)."""

    start: bounds.Point2
    end: bounds.Point2
    thickness: bounds.PartExtent = 0.1
    height: float = Field(default=1.2, ge=bounds.MIN_SIZE_M, le=bounds.WALL_HEIGHT_M)


class Location(_Strict):
    """A semantic location: a named point on the navigation graph where the robot can stand."""

    name: str
    x: bounds.Coord
    y: bounds.Coord


class Box(_Strict):
    """A box-shaped part of a piece of furniture; `center` is its centre in world coordinates."""

    name: str
    size: bounds.PartSize3 = Field(description="full extents x, y, z in metres")
    center: bounds.Point3
    color: Rgba = (0.55, 0.4, 0.25, 1.0)

    @model_validator(mode="after")
    def _positive(self) -> Box:
        if min(self.size) <= 0:
            raise ValueError("size: must be positive in x, y and z")
        return self


class Furniture(_Strict):
    """Static furniture made of boxes (a shelf's layers, a table's top and legs)."""

    name: str
    parts: list[Box] = Field(min_length=1, max_length=bounds.MAX_PARTS)


#: The kinds of articulated furniture: a drawer slides out (a prismatic joint), a cabinet's or a fridge's
#: door swings open (a revolute joint).
ContainerKind = Literal["drawer", "cabinet", "fridge"]
#: The direction a container's opening faces (towards where the robot stands).
Facing = Literal["+x", "-x", "+y", "-y"]


class Container(_Strict):
    """Furniture that opens: a drawer unit, a cabinet or a fridge, built in physics from its dimensions
    (a carcass open at the front, and a drawer that slides out of it or a door hinged on one side).

    Place positions inside it name the container as their `support` (its interior floor: the drawer's
    bottom, the carcass's bottom for a cabinet or a fridge). While it is closed, nothing inside can be
    reached or seen; `open` and `close` drive its joint with a motor (`robocog.shared.containers` has
    the geometry).
    """

    name: str
    kind: ContainerKind
    location: str = Field(description="the location the robot stands at to open it and reach inside")
    center: bounds.Point3 = Field(description="centre of the carcass in world coordinates, metres")
    size: bounds.ContainerSize = Field(
        description="outer extents x, y, z in metres, the closed drawer or door included"
    )
    facing: Facing = Field(description="the side the opening faces, e.g. '-y' for a front towards -y")
    hinge: Literal["left", "right"] = Field(
        default="left", description="the door's hinged side, as seen from the front (cabinet, fridge)"
    )
    wall: bounds.PartExtent = Field(default=0.02, description="panel thickness, metres")
    travel: Annotated[float, Field(gt=0)] | None = Field(
        default=None,
        description="how far it opens: metres a drawer slides out (default 0.8 of its depth), or degrees "
        "a door swings (default 90)",
    )
    color: Rgba = (0.6, 0.45, 0.3, 1.0)

    @model_validator(mode="after")
    def _sound(self) -> Container:
        if min(self.size) <= 4 * self.wall:
            raise ValueError("size: must exceed four wall thicknesses in x, y and z")
        if self.kind != "drawer" and self.travel is not None and not 0 < self.travel <= 120:
            raise ValueError("travel: a door opens by at most 120 degrees")
        depth = self.size[0] if self.facing in ("+x", "-x") else self.size[1]
        if self.kind == "drawer" and self.travel is not None and self.travel >= depth - 2 * self.wall:
            raise ValueError(f"travel: a drawer slides out by less than its depth ({depth:g} m) less two walls")
        return self


class PlacePosition(_Strict):
    """A region on a support surface at a location where one object may rest."""

    location: str
    name: str = Field(description="the position's name within its location, e.g. 'top' or 'floor'")
    center: bounds.Point2
    size: bounds.PartSize2 = Field(
        description="extent of the region in x and y, metres (a drawer's: when it is closed)"
    )
    support: str = Field(description="'floor', 'FURNITURE/PART', or a container's name, the surface an object rests on")


class ObjectStart(_Strict):
    """Where an object starts: on a place position, or at an explicit pose (e.g. a TV on its table)."""

    location: str | None = None
    position: str | None = None
    pose: bounds.Point3 | None = None
    yaw: bounds.Angle = 0.0

    @model_validator(mode="after")
    def _one_kind(self) -> ObjectStart:
        on_position = self.location is not None and self.position is not None
        if on_position == (self.pose is not None):
            raise ValueError("give either location and position, or pose")
        return self


#: One referring expression: words, no line breaks, at most a name's length.
Description = Annotated[str, Field(min_length=1, max_length=NAME_CHARS, pattern=r"^[^\r\n]*\S[^\r\n]*$")]


def referring_key(text: str) -> str:
    """How a name or description is compared: `robocog.shared.names.name_key` (case, spaces and
    surrounding punctuation do not matter; a leading article is dropped: "The  Drinking vessel" ->
    "drinking vessel")."""
    return name_key(text)


class SceneObject(_Strict):
    """A movable object. Primitive shapes are built from `size`; `urdf` loads a pybullet_data model."""

    name: str
    shape: Literal["box", "cylinder", "urdf"] = "box"
    size: bounds.ObjectSize = Field(
        description="bounding extents x, y, z in metres (for a cylinder: diameter, diameter, height)"
    )
    urdf: str | None = Field(default=None, description="path inside pybullet_data, e.g. objects/mug.urdf")
    urdf_scale: float = Field(default=1.0, ge=bounds.MIN_SCALE, le=bounds.MAX_SCALE)
    mass: float = Field(default=0.2, ge=bounds.MIN_MASS_KG, le=bounds.MAX_MASS_KG)
    color: Rgba = (0.8, 0.2, 0.2, 1.0)
    graspable: bool = True
    start: ObjectStart
    descriptions: list[Description] = Field(
        default=[],
        max_length=bounds.MAX_DESCRIPTIONS,
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

    time_step: float = Field(default=1.0 / 120.0, ge=bounds.MIN_TIME_STEP_S, le=bounds.MAX_TIME_STEP_S)
    gravity: float = Field(default=-9.81, ge=-bounds.GRAVITY, le=bounds.GRAVITY)
    solver_iterations: int = Field(default=50, ge=1, le=bounds.SOLVER_ITERATIONS)
    settle_steps: int = Field(
        default=120, ge=1, le=bounds.SETTLE_STEPS, description="most steps a released object may take to rest"
    )
    rest_speed: float = Field(
        default=0.02, gt=0, le=bounds.REST_SPEED, description="m/s under which an object counts as resting"
    )


class Scene(_Strict):
    """A whole household scene."""

    name: str
    robot: str = Field(default="robot/iiwa_mobile.yaml", description="robot description, relative to assets/")
    robot_start: str = Field(description="the location where the robot starts")
    physics: Physics = Physics()
    rooms: list[Room] = Field(default=[], max_length=bounds.MAX_ROOMS)
    walls: list[Wall] = Field(default=[], max_length=bounds.MAX_WALLS)
    locations: list[Location] = Field(min_length=1, max_length=bounds.MAX_LOCATIONS)
    edges: list[tuple[str, str]] = Field(default=[], max_length=bounds.MAX_EDGES)
    furniture: list[Furniture] = Field(default=[], max_length=bounds.MAX_FURNITURE)
    containers: list[Container] = Field(default=[], max_length=bounds.MAX_CONTAINERS)
    place_positions: list[PlacePosition] = Field(default=[], max_length=bounds.MAX_PLACE_POSITIONS)
    objects: list[SceneObject] = Field(default=[], max_length=bounds.MAX_OBJECTS)
    location_radius: float = Field(
        default=1.3,
        gt=0,
        le=bounds.LOCATION_RADIUS_M,
        description="how far from a location an object may lie and still be seen as 'at' it",
    )
    perturbations: list[Perturbation] = Field(
        default=[], max_length=MAX_PERTURBATIONS, description="what goes wrong in every episode (none by default)"
    )

    @model_validator(mode="after")
    def _consistent(self) -> Scene:
        names = [loc.name for loc in self.locations]
        _unique("locations", names)
        _unique("objects", [o.name for o in self.objects])
        _unique("furniture and containers", [f.name for f in self.furniture] + [c.name for c in self.containers])
        known = set(names)
        if self.robot_start not in known:
            raise ValueError(f"robot_start: {self.robot_start!r} is not a location (known: {sorted(known)})")
        for i, (a, b) in enumerate(self.edges):
            for end in (a, b):
                if end not in known:
                    raise ValueError(f"edges[{i}]: {end!r} is not a location")
        parts = {f"{f.name}/{p.name}" for f in self.furniture for p in f.parts}
        for i, box in enumerate(self.containers):
            if box.location not in known:
                raise ValueError(f"containers[{i}] ({box.name}): location {box.location!r} is not a location")
        parts |= {c.name for c in self.containers}
        seen: set[tuple[str, str]] = set()
        for i, pos in enumerate(self.place_positions):
            if pos.location not in known:
                raise ValueError(f"place_positions[{i}]: location {pos.location!r} is not a location")
            if pos.support != "floor" and pos.support not in parts:
                raise ValueError(
                    f"place_positions[{i}]: support {pos.support!r} is neither 'floor', a furniture part nor a "
                    f"container (known: {sorted(parts)})"
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
        problem = next(iter(self.perturbation_problems(self.perturbations)), None)
        if problem is not None:
            raise ValueError(problem)
        return self

    def perturbation_problems(self, perturbations: list[Perturbation]) -> list[str]:
        """What in `perturbations` names something this scene lacks (an object, a place position, a
        container, an edge), one line each."""
        objects = {o.name for o in self.objects if o.graspable}
        spots = {(p.location, p.name) for p in self.place_positions}
        boxes = {c.name for c in self.containers}
        edges = {frozenset(e) for e in self.edges}
        out: list[str] = []
        for i, p in enumerate(perturbations):
            where = f"perturbations[{i}] ({p.kind})"
            if p.object is not None and p.object not in objects:
                out.append(f"{where}: {p.object!r} is not a graspable object (known: {sorted(objects)})")
            if p.to is not None and tuple(p.to) not in spots:
                out.append(f"{where}: {p.to[0]} / {p.to[1]} is not a place position")
            if p.container is not None and p.container not in boxes:
                out.append(f"{where}: {p.container!r} is not a container (known: {sorted(boxes)})")
            if p.edge is not None and frozenset(p.edge) not in edges:
                out.append(f"{where}: {p.edge[0]} - {p.edge[1]} is not an edge of the map")
        return out

    def robot_file(self) -> Path:
        """The robot description this scene names (relative paths are inside assets/)."""
        return ASSETS_DIR / self.robot

    def described_as(self, text: str) -> list[str]:
        """The objects (scene order) that `text` refers to: by name or by one of their descriptions,
        compared without case, extra spaces or a leading article. Several when the text is ambiguous."""
        key = referring_key(text)
        return [o.name for o in self.objects if key in {referring_key(o.name), *map(referring_key, o.descriptions)}]

    def container(self, name: str) -> Container:
        """The container called `name` (exact)."""
        for box in self.containers:
            if box.name == name:
                return box
        raise KeyError(name)

    def location(self, name: str) -> Location:
        """The location called `name` (exact)."""
        for loc in self.locations:
            if loc.name == name:
                return loc
        raise KeyError(name)


def _unique(what: str, names: list[str]) -> None:
    counts = Counter(names)
    dupes = sorted(n for n, k in counts.items() if k > 1)
    if dupes:
        raise ValueError(f"{what}: duplicate names {dupes}")
