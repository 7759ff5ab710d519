"""Ground truth over a `Sim`: where each object is, which positions are taken, where the robot stands.

Everything here is read from the physics state (poses, velocities, contacts), never from
bookkeeping, and nothing here changes the simulation.
"""

from __future__ import annotations

from robocog.server.world import containers
from robocog.server.world.sim import Body, Position, Sim
from robocog.shared.results import FurnitureState, ObjectPlacement, PositionState, RobotState, WorldState


def touches(sim: Sim, body: int, support: int) -> bool:
    return bool(sim.client.getClosestPoints(body, support, 0.005))


def position_of(sim: Sim, obj: Body) -> Position | None:
    """The place position whose region holds the object's footprint at its surface height."""
    (x, y, _z), _ = sim.client.getBasePositionAndOrientation(obj.body)
    bottom = sim.client.getAABB(obj.body)[0][2]
    for pos in sim.positions.values():
        if sim.holds_xy(pos, x, y) and pos.surface_z - 0.02 <= bottom <= pos.surface_z + 0.08:
            return pos
    return None


def holding(sim: Sim) -> str | None:
    """The object in the robot's hand, if any."""
    return sim.grasp.name if sim.grasp else None


def robot_location(sim: Sim) -> str:
    """The location the robot stands at (the nearest one; it only ever stops at locations)."""
    name, _ = sim.map.nearest(sim.robot.x, sim.robot.y)
    return name


def placement(sim: Sim, name: str) -> ObjectPlacement:
    """Where the object `name` is, from the physics state."""
    obj = sim.objects[name]
    (x, y, z), _ = sim.client.getBasePositionAndOrientation(obj.body)
    room = next((r.name for r in sim.scene.rooms if r.x[0] <= x <= r.x[1] and r.y[0] <= y <= r.y[1]), None)
    inside = containers.container_at(sim, (x, y, z)) if sim.containers else None
    if holding(sim) == name:
        return ObjectPlacement(
            object=name,
            state="held",
            location=robot_location(sim),
            xyz=(x, y, z),
            resting=False,
            room=room,
            inside=inside,
        )
    resting = sim.speed(obj.body) < sim.scene.physics.rest_speed
    pos = position_of(sim, obj)
    if pos is not None and resting and touches(sim, obj.body, pos.support_body):
        return ObjectPlacement(
            object=name,
            state="on_position",
            location=pos.spec.location,
            position=pos.spec.name,
            xyz=(x, y, z),
            resting=True,
            room=room,
            inside=inside,
        )
    near, dist = sim.map.nearest(x, y)
    supported = resting and any(touches(sim, obj.body, b) for b in sim.static_bodies)
    return ObjectPlacement(
        object=name,
        state="loose",
        location=near if dist <= sim.scene.location_radius else None,
        xyz=(x, y, z),
        resting=supported,
        room=room,
        inside=inside,
    )


def placements(sim: Sim) -> dict[str, ObjectPlacement]:
    """Every object's placement, in scene order."""
    return {name: placement(sim, name) for name in sim.objects}


def occupant(sim: Sim, position: Position, ignore: str | None = None) -> str | None:
    """The object (other than `ignore` and the held one) lying in a position's region, moving or not."""
    held = holding(sim)
    for name, obj in sim.objects.items():
        if name in (ignore, held):
            continue
        if position_of(sim, obj) is position:
            return name
    return None


def state(sim: Sim) -> WorldState:
    """The whole ground truth."""
    by_name = placements(sim)
    by_position = {(p.location, p.position): p.object for p in by_name.values() if p.state == "on_position"}
    z = sim.robot_spec.base_size[2] / 2
    return WorldState(
        robot=RobotState(
            location=robot_location(sim),
            xyz=(sim.robot.x, sim.robot.y, z),
            yaw=sim.robot.yaw,
            holding=holding(sim),
        ),
        objects=list(by_name.values()),
        positions=[
            PositionState(location=loc, position=name, occupied_by=by_position.get((loc, name)))
            for loc, name in sim.positions
        ],
        sim_time_s=sim.steps * sim.scene.physics.time_step,
        steps=sim.steps,
        furniture=[furniture(sim, name, by_name) for name in sim.containers],
    )


def furniture(sim: Sim, name: str, by_name: dict[str, ObjectPlacement] | None = None) -> FurnitureState:
    """A container's state from its joint, and the objects its interior holds."""
    spec = sim.containers[name].geometry.spec
    by_name = by_name if by_name is not None else placements(sim)
    return FurnitureState(
        name=name,
        kind=spec.kind,
        location=spec.location,
        state="closed" if containers.is_closed(sim, name) else "open",
        opening=round(containers.opening(sim, name), 3),
        contents=[p.object for p in by_name.values() if p.inside == name],
    )


def hidden(sim: Sim, where: ObjectPlacement) -> str | None:
    """The closed container an object is shut in (it can be neither seen nor reached), if any."""
    if where.inside is not None and where.state != "held" and containers.is_closed(sim, where.inside):
        return where.inside
    return None


def shut_position(sim: Sim, position: Position) -> str | None:
    """The closed container a place position is inside, if any."""
    if position.container is not None and containers.is_closed(sim, position.container):
        return position.container
    return None
