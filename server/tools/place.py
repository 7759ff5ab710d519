"""place: put the held object down on a free place position where the robot is."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import ACTION, Tool, at_most
from robocog.server.tools.names import LocationArg, unknown_location
from robocog.server.world.navigation import closest, resolve
from robocog.shared.limits import NAME_CHARS
from robocog.shared.results import ErrorCode, PlaceResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

PositionArg = Annotated[
    str,
    Field(
        description="A place position of that location as look_around lists it, e.g. 'top', "
        "'middle', 'bottom' or 'floor'",
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give the position's name as look_around lists it"),
]


def place(robot: RobotSession, location: LocationArg, position: PositionArg) -> PlaceResult:
    """Put the held object down on a free place position of the location where the robot is.
    Fails if nothing is held, the robot is elsewhere, the position is unknown or occupied
    (the message lists the free positions)."""
    world = robot.world
    held = world.holding
    if held is None:
        return _failure(
            "nothing_held", "The robot is not holding anything. Grab an object first.", None, location, position
        )
    here = world.robot_location()
    loc = resolve(location, world.map.names)
    if loc is None:
        message, suggestions = unknown_location(world, location)
        return _failure("unknown_location", message, held, location, position, suggestions=suggestions)
    names = world.position_names(loc)
    if loc != here:
        message = f"The robot is at {here}, not at {loc}. move_to('{loc}') first."
        return _failure("not_at_location", message, held, loc, position)
    pname = resolve(position, names)
    if pname is None:
        listing = ", ".join(names) if names else "none (nothing can be placed here)"
        message = f"{loc} has no place position {position!r}. Its positions: {listing}."
        return _failure("unknown_position", message, held, loc, position, suggestions=closest(position, names) or names)
    shut = world.shut_position(loc, pname)
    if shut is not None:
        inside = shut.replace("_", " ")
        message = f"The {pname} position of {loc} is inside the {inside}, which is closed. open('{shut}') first."
        return _failure("out_of_reach", message, held, loc, pname, container=shut)
    occupant = world.occupant(loc, pname, ignore=held)
    if occupant is not None:
        free = [p for p in names if world.occupant(loc, p, ignore=held) is None]
        alternatives = f" Free positions here: {', '.join(free)}." if free else f" No position at {loc} is free."
        message = f"The {pname} position of {loc} is occupied by the {occupant}.{alternatives}"
        return _failure("position_occupied", message, held, loc, pname, suggestions=free)
    reach = world.put_down(loc, pname)
    if reach.failure == "unreachable":
        message = f"The arm cannot reach the {pname} position of {loc} ({reach.gap_m:.2f} m short)."
        return _failure("out_of_reach", message, held, loc, pname)
    where = reach.placement
    assert where is not None
    if not reach.ok:
        ended = f"{where.location} / {where.position}" if where.position else f"near {where.location}"
        message = f"The {held} was released but did not come to rest on {loc} / {pname}; it is {ended}."
        return _failure("place_failed", message, held, loc, pname, released=True)
    return PlaceResult(
        status="success",
        message=f"Placed the {held} on the {pname} position of {loc}.",
        object=held,
        location=loc,
        position=pname,
    )


def _failure(
    error: ErrorCode,
    message: str,
    held: str | None,
    location: str,
    position: str,
    *,
    suggestions: list[str] | None = None,
    released: bool = False,
    container: str | None = None,
) -> PlaceResult:
    """A failed place of `held` (still in the hand unless `released`) at `location` / `position`."""
    return PlaceResult(
        status="failure",
        error=error,
        message=message,
        suggestions=suggestions or [],
        object=held,
        location=location,
        position=position,
        holding=None if released else held,
        container=container,
    )


TOOL = Tool("place", "Place the held object", ACTION, place, changes_world=True)
