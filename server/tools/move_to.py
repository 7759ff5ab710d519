"""move_to: drive to a location along the shortest path on the semantic map."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robocog.server.tools.base import IDEMPOTENT_ACTION, Tool
from robocog.server.tools.names import LocationArg, unknown_location
from robocog.server.world.navigation import resolve
from robocog.shared.results import MoveResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession


def move_to(robot: RobotSession, location: LocationArg) -> MoveResult:
    """Drive the robot to a location along the shortest path on its map (A*). Fails with the
    closest known names if the location does not exist, or if there is no path; if the way is
    blocked, it stops at the last location before the block and says where."""
    world = robot.world
    here = world.robot_location()
    goal = resolve(location, world.map.names)
    if goal is None:
        message, suggestions = unknown_location(world, location)
        return MoveResult(
            status="failure", error="unknown_location", message=message, suggestions=suggestions, location=here
        )
    path = world.map.shortest_path(here, goal)
    if path is None:
        return MoveResult(
            status="failure",
            error="no_path",
            message=f"There is no path from {here} to {goal} on the map.",
            location=here,
        )
    if len(path) == 1:
        return MoveResult(status="success", message=f"The robot is already at {goal}.", location=goal, path=path)
    trip = world.travel(path, robot.caller.report)
    driven = trip.driven_m
    if trip.blocked is not None:
        a, b = trip.blocked
        stopped = trip.path[-1]
        via = f" via {' -> '.join(trip.path)} ({driven:.1f} m)" if len(trip.path) > 1 else ""
        return MoveResult(
            status="failure",
            error="no_path",
            message=f"The way from {a} to {b} is blocked, so the robot could not reach {goal}: it stopped at "
            f"{stopped}{via}. "
            + (
                "It will not clear: go another way if there is one."
                if trip.for_good
                else "The block may clear later: try again in a while, or go another way."
            ),
            location=stopped,
            path=trip.path,
            distance_m=round(driven, 3),
        )
    return MoveResult(
        status="success",
        message=f"Moved to {goal} via {' -> '.join(path)} ({driven:.1f} m).",
        location=goal,
        path=path,
        distance_m=round(driven, 3),
    )


TOOL = Tool("move_to", "Move to a location", IDEMPOTENT_ACTION, move_to, changes_world=True)
