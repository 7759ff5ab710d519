"""look_around: what the robot perceives (a read-only tool)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robocog.server.tools.base import READ_ONLY, Tool
from robocog.shared.results import LocationView, LookAroundResult, PositionView

if TYPE_CHECKING:
    from robocog.server.session import RobotSession


def look_around(robot: RobotSession) -> LookAroundResult:
    """Perceive the world: where the robot is, what it holds, and for every location its objects,
    its place positions (free or occupied) and its neighbouring locations."""
    world = robot.world
    placements = world.placements()
    here, holding = world.robot_location(), world.holding
    views = [
        LocationView(
            name=name,
            neighbours=list(world.map.neighbours[name]),
            objects=[p.object for p in placements.values() if p.state != "held" and p.location == name],
            place_positions=[
                PositionView(name=position, occupied_by=world.occupant(name, position))
                for position in world.position_names(name)
            ],
        )
        for name in world.map.names
    ]
    hand = f"holding the {holding}" if holding else "holding nothing"
    visible = next(v for v in views if v.name == here)
    seen = ", ".join(visible.objects) or "no objects"
    return LookAroundResult(
        status="success",
        message=f"The robot is at {here}, {hand}. Here: {seen}.",
        location=here,
        holding=holding,
        locations=views,
    )


TOOL = Tool("look_around", "Look around", READ_ONLY, look_around)
