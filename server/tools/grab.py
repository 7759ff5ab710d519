"""grab: pick up an object at the robot's location."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field

from robocog.server.tools.base import ACTION, Tool, at_most
from robocog.server.tools.names import unknown_object
from robocog.server.world.navigation import resolve
from robocog.shared.limits import NAME_CHARS
from robocog.shared.results import GrabResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

ObjectArg = Annotated[
    str,
    Field(
        description="The object to pick up, e.g. 'mug'; it must be at the robot's location",
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give the object's name as look_around lists it"),
]


def grab(robot: RobotSession, object: ObjectArg) -> GrabResult:
    """Reach for an object at the robot's location and hold it. The robot holds one object at a
    time; fails if the object is unknown, elsewhere, out of reach, too large to grasp, or if the
    hand is already full."""
    world = robot.world
    name = resolve(object, world.object_names)
    if name is None:
        message, suggestions = unknown_object(world, object)
        return GrabResult(
            status="failure",
            error="unknown_object",
            message=message + " Use look_around to see where they are.",
            suggestions=suggestions,
            object=object,
            holding=world.holding,
        )
    held = world.holding
    if held is not None:
        verb = "already holding it" if held == name else f"already holding the {held}"
        return GrabResult(
            status="failure",
            error="already_holding",
            message=f"The robot is {verb}; it holds one object at a time. Place the {held} first.",
            object=name,
            holding=held,
        )
    if not world.object_spec(name).graspable:
        return _out(name, "not_graspable", f"The {name} cannot be grasped: it is too large or heavy for the robot.")
    shut = world.shut_in(name)
    if shut is not None:
        spec = world.scene.container(shut)
        message = (
            f"The {name} cannot be reached: it is inside the {shut.replace('_', ' ')}, which is closed. "
            f"open('{shut}') at {spec.location} first."
        )
        return GrabResult(status="failure", message=message, error="out_of_reach", object=name, container=shut)
    here = world.robot_location()
    where = world.placement(name)
    if where.location != here:
        hint = (
            f"it is at {where.location}; move_to('{where.location}') first"
            if where.location
            else ("it is not near any location the robot can reach")
        )
        return _out(name, "out_of_reach", f"The {name} is out of reach from {here}: {hint}.")
    reach = world.pick(name)
    if reach.failure == "unreachable":
        message = f"The arm cannot reach the {name} from where the robot stands ({reach.gap_m:.2f} m short)."
        return _out(name, "out_of_reach", message)
    if not reach.ok:
        message = f"The hand stopped {reach.gap_m:.2f} m from the {name}; it could not be grasped from here."
        return _out(name, "out_of_reach", message)
    origin = f"{where.location} / {where.position}" if where.position else str(where.location)
    return GrabResult(status="success", message=f"Grabbed the {name} from {origin}.", object=name, holding=name)


def _out(name: str, error: Literal["not_graspable", "out_of_reach"], message: str) -> GrabResult:
    """A failure that leaves the hand empty."""
    return GrabResult(status="failure", error=error, message=message, object=name)


TOOL = Tool("grab", "Grab an object", ACTION, grab, changes_world=True)
