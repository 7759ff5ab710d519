"""The bounds of a scene file and of a robot description, written down once.

A value outside them is refused when the file is loaded, in one line naming the field (a location at
x = 1e15 or a time step of 1e-9 would otherwise take the physics down, a 10,000-object scene would
take minutes to build). They are generous: the shipped scenes and the generated houses use a fraction
of each. The field types below carry them into the schemas (`robocog.shared.scene`,
`robocog.shared.robot_spec`); docs/world.md ("Bounds") lists them, and a test holds the two equal.
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field

#: Metres from the origin that any point of a scene may lie (x, y and z): a house within 200 m x 200 m.
COORD_M = 100.0
#: The smallest extent of anything with a size (a part, an object, a region, a wall), metres.
MIN_SIZE_M = 0.005
#: The largest extent of a piece of furniture's part, a place position's region, a wall's thickness.
PART_M = 50.0
#: The largest extent of a movable object (a TV is about 1 m), metres.
OBJECT_M = 5.0
#: The largest extent of a container (a fridge is about 2 m), metres.
CONTAINER_M = 10.0
#: The tallest wall, metres.
WALL_HEIGHT_M = 20.0
#: An object's mass, kilograms.
MIN_MASS_KG, MAX_MASS_KG = 0.001, 1000.0
#: A URDF object's scale.
MIN_SCALE, MAX_SCALE = 0.01, 10.0
#: The physics time step, seconds (PyBullet's default is 1/240; the shipped scenes use 1/120).
MIN_TIME_STEP_S, MAX_TIME_STEP_S = 0.001, 0.05
#: Gravity, m/s² (either sign).
GRAVITY = 100.0
#: The solver's iterations per step, and the steps a released object may take to rest.
SOLVER_ITERATIONS = 1_000
SETTLE_STEPS = 10_000
#: The speed under which an object rests, m/s; the radius an object is "at" a location within, m.
REST_SPEED = 10.0
LOCATION_RADIUS_M = 10.0
#: An angle (a yaw, a joint of a pose), radians either way: one turn.
ANGLE_RAD = 2 * math.pi

#: How many of each a scene may have.
MAX_ROOMS = 100
MAX_WALLS = 500
MAX_LOCATIONS = 200
MAX_EDGES = 1_000
MAX_FURNITURE = 200
MAX_PARTS = 50  # per piece of furniture
MAX_CONTAINERS = 50
MAX_PLACE_POSITIONS = 500
MAX_OBJECTS = 100
MAX_DESCRIPTIONS = 20  # per object
#: The largest scene file, bytes (a generated house is about 18 KB): YAML is read at about 0.4 MB/s here,
#: so a file of 10,000 objects (1.2 MB) took seconds to parse before any count was checked.
SCENE_FILE_BYTES = 256 * 1024

#: A robot's base: its extents (metres) and speed (m/s); its arm's joint speed (rad/s), joints.
BASE_MIN_M, BASE_MAX_M = 0.05, 5.0
BASE_SPEED = (0.01, 20.0)
JOINT_SPEED = (0.01, 50.0)
MAX_JOINTS = 64
#: How far the hand may be from its target and still grasp, and the clearances, metres.
GRASP_M = 1.0

#: What one robot action (one tool call) may take: simulated steps, and seconds of wall time. An action
#: past either stops and its call returns an error saying so (a drive that would take more steps is
#: refused before the robot moves).
ACTION_STEPS = 100_000
ACTION_WALL_S = 60.0

Coord = Annotated[float, Field(ge=-COORD_M, le=COORD_M)]
Point2 = tuple[Coord, Coord]
Point3 = tuple[Coord, Coord, Coord]
PartExtent = Annotated[float, Field(ge=MIN_SIZE_M, le=PART_M)]
PartSize2 = tuple[PartExtent, PartExtent]
PartSize3 = tuple[PartExtent, PartExtent, PartExtent]
ObjectExtent = Annotated[float, Field(ge=MIN_SIZE_M, le=OBJECT_M)]
ObjectSize = tuple[ObjectExtent, ObjectExtent, ObjectExtent]
ContainerExtent = Annotated[float, Field(ge=MIN_SIZE_M, le=CONTAINER_M)]
ContainerSize = tuple[ContainerExtent, ContainerExtent, ContainerExtent]
Angle = Annotated[float, Field(ge=-ANGLE_RAD, le=ANGLE_RAD)]
BaseExtent = Annotated[float, Field(ge=BASE_MIN_M, le=BASE_MAX_M)]

#: The bounds as docs/world.md lists them: (what, bound), one row each.
TABLE: tuple[tuple[str, str], ...] = (
    ("any coordinate (x, y, z of a location, a centre, a wall's end, a pose, a room's edges)", f"±{COORD_M:g} m"),
    ("a part's, a place position's or a wall's extent", f"{MIN_SIZE_M:g} to {PART_M:g} m"),
    ("an object's extent", f"{MIN_SIZE_M:g} to {OBJECT_M:g} m"),
    ("a container's extent", f"{MIN_SIZE_M:g} to {CONTAINER_M:g} m"),
    ("a wall's height", f"{MIN_SIZE_M:g} to {WALL_HEIGHT_M:g} m"),
    ("an object's mass", f"{MIN_MASS_KG:g} to {MAX_MASS_KG:g} kg"),
    ("a URDF object's scale", f"{MIN_SCALE:g} to {MAX_SCALE:g}"),
    ("a yaw, a joint angle of a pose", "±2π rad"),
    ("physics: time_step", f"{MIN_TIME_STEP_S:g} to {MAX_TIME_STEP_S:g} s"),
    ("physics: gravity", f"±{GRAVITY:g} m/s²"),
    ("physics: solver_iterations, settle_steps", f"at most {SOLVER_ITERATIONS:,}, {SETTLE_STEPS:,}"),
    ("physics: rest_speed; location_radius", f"at most {REST_SPEED:g} m/s; {LOCATION_RADIUS_M:g} m"),
    ("rooms, walls, locations, edges", f"at most {MAX_ROOMS}, {MAX_WALLS}, {MAX_LOCATIONS}, {MAX_EDGES:,}"),
    (
        "furniture (parts each), containers, place positions",
        f"at most {MAX_FURNITURE} ({MAX_PARTS}), {MAX_CONTAINERS}, {MAX_PLACE_POSITIONS}",
    ),
    ("objects (descriptions each)", f"at most {MAX_OBJECTS} ({MAX_DESCRIPTIONS})"),
    ("the scene file", f"at most {SCENE_FILE_BYTES // 1024} KB"),
    (
        "robot: base extents; base speed",
        f"{BASE_MIN_M:g} to {BASE_MAX_M:g} m; {BASE_SPEED[0]:g} to {BASE_SPEED[1]:g} m/s",
    ),
    ("robot: joint speed; joints in a pose", f"{JOINT_SPEED[0]:g} to {JOINT_SPEED[1]:g} rad/s; at most {MAX_JOINTS}"),
    ("robot: grasp threshold, clearances", f"at most {GRASP_M:g} m"),
    ("one robot action (a tool call)", f"at most {ACTION_STEPS:,} simulated steps and {ACTION_WALL_S:g} s"),
)
