"""look_around: what the robot perceives (a read-only tool)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from robocog.server.tools.base import READ_ONLY, Tool
from robocog.shared.results import FurnitureView, LocationView, LookAroundResult, PositionView

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession


def look_around(robot: RobotSession) -> LookAroundResult:
    """Perceive the world: where the robot is, what it holds, and for every location its objects,
    its place positions (free or occupied) and its neighbouring locations."""
    world = robot.world
    placements = world.placements()
    here, holding = world.robot_location(), world.holding
    observed = world.observed_locations(robot.observing)
    shown = [p for p in placements.values() if p.state != "held" and not world.hidden(p)]
    views = [
        LocationView(
            name=name,
            neighbours=list(world.map.neighbours[name]),
            objects=[p.object for p in shown if p.location == name],
            place_positions=[
                PositionView(name=position, occupied_by=world.occupant(name, position))
                for position in world.visible_positions(name)
            ],
        )
        for name in observed
    ]
    furniture = [
        FurnitureView(name=f.name, kind=f.kind, location=f.location, state=f.state)
        for f in map(world.furniture, world.container_names)
        if f.location in observed
    ]
    hand = f"holding the {holding}" if holding else "holding nothing"
    visible = next(v for v in views if v.name == here)
    seen = ", ".join(visible.objects) or "no objects"
    message = f"The robot is at {here}, {hand}. Here: {seen}."
    if robot.describing:  # robocog-v2.1: what a person sees of each object in view
        in_view = [p.object for p in shown if p.location in observed] + ([holding] if holding else [])
        looks = [f"{name} ({', '.join(world.appearance(name))})" for name in in_view]
        message += f" Seen: {', '.join(looks)}." if looks else ""
    if robot.observing != "house":
        scope = "this location" if robot.observing == "location" or len(observed) == 1 else "this room"
        message += f" Only {scope} can be seen from here; move elsewhere to see more."
    return LookAroundResult(
        status="success",
        message=message,
        location=here,
        holding=holding,
        locations=views,
        furniture=furniture,
        observed=None if robot.observing == "house" else robot.observing,
    )


TOOL = Tool("look_around", "Look around", READ_ONLY, look_around)
