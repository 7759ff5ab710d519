"""open(furniture) and close(furniture): the robot drives a drawer or a door with its arm.

The robot must stand at the furniture's location with its hand free; the arm goes to the handle and
the joint's motor drives the drawer or the door within its force limit, so the result reports what
physics did: opened or closed, already so, or blocked (something stopped it short). While a container
is closed, what is inside can be neither seen (look_around) nor reached (grab, place).

Under the paper's protocol a client offers neither tool (`robocog.shared.protocol.FURNITURE_TOOLS`):
the paper's models had its eight tools.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import ACTION, Tool, at_most
from robocog.server.tools.names import and_list
from robocog.server.world.navigation import closest, resolve, strip_articles
from robocog.shared.limits import NAME_CHARS
from robocog.shared.results import FurnitureError, OpenCloseResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession
    from robocog.server.world.world import World

FurnitureArg = Annotated[
    str,
    Field(
        description="Furniture that opens, as look_around lists it under 'furniture', e.g. 'kitchen_drawer' "
        "or 'fridge'",
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give the furniture's name as look_around lists it"),
]

#: Fully open from this fraction on: open() on it is "already open".
FULLY_OPEN = 0.97


def open_furniture(robot: RobotSession, furniture: FurnitureArg) -> OpenCloseResult:
    """Open a drawer, a cabinet or a fridge: the robot must be at its location with its hand free. The
    arm pulls the handle; the result says whether it opened or something blocked it. What is inside a
    closed container can be neither seen nor reached until it is opened."""
    return _operate(robot, furniture, opened=True)


def close_furniture(robot: RobotSession, furniture: FurnitureArg) -> OpenCloseResult:
    """Close a drawer, a cabinet or a fridge: the robot must be at its location with its hand free. The
    arm pushes the handle; the result says whether it closed or something blocked it."""
    return _operate(robot, furniture, opened=False)


def _operate(robot: RobotSession, furniture: str, *, opened: bool) -> OpenCloseResult:
    world = robot.world
    verb = "open" if opened else "close"
    names = world.container_names
    name = resolve(furniture, names) or resolve(strip_articles(furniture), names)
    if name is None:
        return _unknown(world, furniture, verb)
    spec = world.scene.container(name)
    here = world.robot_location()
    if here != spec.location:
        message = (
            f"The robot is at {here}; the {_display(name)} is at {spec.location}. move_to('{spec.location}') first."
        )
        return _failure("not_at_location", message, name)
    held = world.holding
    if held is not None:
        message = f"Opening and closing needs the robot's hand free, and it holds the {held}. Place the {held} first."
        return _failure("already_holding", message, name)
    before = world.furniture(name)
    if opened and before.opening >= FULLY_OPEN:
        return _result(world, name, "already_open", f"The {_display(name)} is already open.{_contents(world, name)}")
    if not opened and before.state == "closed":
        return _result(world, name, "already_closed", f"The {_display(name)} is already closed.")
    op = world.operate(name, opened=opened)
    part = "drawer" if spec.kind == "drawer" else "door"
    if op.outcome == "unreachable":
        message = f"The arm cannot reach the handle of the {_display(name)} from {here} ({op.gap_m:.2f} m short)."
        return _failure("out_of_reach", message, name)
    if op.outcome == "blocked":
        after = world.furniture(name)
        way = world.blocking(name)
        cause = f"the {and_list(way)} is in the way" if way else "something is in the way"
        message = (
            f"The {_display(name)}'s {part} stopped {after.opening:.0%} open and would not {verb} further: {cause}."
        )
        result = _result(world, name, "blocked", message, steps=op.steps)
        return result.model_copy(update={"status": "failure", "error": "blocked"})
    if opened:
        return _result(world, name, "opened", f"Opened the {_display(name)}.{_contents(world, name)}", steps=op.steps)
    return _result(world, name, "closed", f"Closed the {_display(name)}.", steps=op.steps)


def _display(name: str) -> str:
    return name.replace("_", " ")


def _contents(world: World, name: str) -> str:
    inside = world.furniture(name).contents
    return f" Inside: {and_list(inside)}." if inside else " It is empty."


def _unknown(world: World, furniture: str, verb: str) -> OpenCloseResult:
    names = world.container_names
    bare = strip_articles(furniture)
    static = [piece for piece in world.furniture_locations() if piece not in names]
    piece = resolve(bare, static)
    openable = f" Furniture that opens: {', '.join(names)}." if names else " Nothing here opens."
    if piece is not None:
        message = f"The {_display(piece)} does not {verb}: it has no door or drawer.{openable}"
        return _failure("not_openable", message, furniture)
    if resolve(bare, world.object_names) is not None or resolve(bare, world.map.names) is not None:
        message = f"{furniture!r} is not furniture that opens.{openable}"
        return _failure("not_openable", message, furniture)
    suggestions = closest(furniture, names)
    guess = f" Did you mean {', '.join(repr(s) for s in suggestions)}?" if suggestions else ""
    return _failure(
        "unknown_furniture", f"There is no furniture called {furniture!r}.{guess}{openable}", furniture, suggestions
    )


def _failure(
    error: FurnitureError, message: str, furniture: str, suggestions: list[str] | None = None
) -> OpenCloseResult:
    return OpenCloseResult(
        status="failure", error=error, message=message, furniture=furniture, suggestions=suggestions or []
    )


def _result(world: World, name: str, outcome: str, message: str, *, steps: int = 0) -> OpenCloseResult:
    state = world.furniture(name)
    return OpenCloseResult.model_validate(
        {
            "status": "success",
            "message": message,
            "furniture": name,
            "outcome": outcome,
            "state": state.state,
            "opening": state.opening,
            "steps": steps,
        }
    )


OPEN = Tool("open", "Open a drawer or door", ACTION, open_furniture, changes_world=True)
CLOSE = Tool("close", "Close a drawer or door", ACTION, close_furniture, changes_world=True)
