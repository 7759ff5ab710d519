"""The oracle's tour of a house (the generated houses' physics test and bench): every object at rest on its
start position, every container opened, then one object carried over every free place position with the
world's own actions, ground truth reporting it resting on each."""

from __future__ import annotations

from robocog.server.world.world import World


def drive_to(world: World, location: str) -> None:
    path = world.map.shortest_path(world.robot_location(), location)
    assert path is not None, f"no path to {location}"
    world.drive(path)


def start_problems(world: World) -> list[str]:
    """Objects not resting on their start position after a reset, one line each."""
    problems = []
    for name, where in world.placements().items():
        start = world.object_spec(name).start
        if (where.state, where.location, where.position, where.resting) != (
            "on_position",
            start.location,
            start.position,
            True,
        ):
            problems.append(f"{name} starts {where.state} at {where.location} / {where.position}, not on its start")
    return problems


def tour(world: World) -> tuple[int, int, list[str]]:
    """Open every container, then carry the smallest object over every free place position and back home.
    The positions reached, the positions tried, and what went wrong (one line each)."""
    problems: list[str] = []
    for name in world.container_names:
        drive_to(world, world.scene.container(name).location)
        opened = world.operate(name, opened=True)
        if opened.outcome != "done":
            problems.append(f"open {name}: {opened.outcome}")
    carried = min(world.object_names, key=lambda o: (max(world.object_spec(o).size), o))
    start = world.placement(carried)
    home = (str(start.location), str(start.position))
    drive_to(world, home[0])
    if not world.pick(carried).ok:
        return 0, 0, [*problems, f"cannot pick {carried} from {home}"]
    free = [key for key in world.sim.positions if world.occupant(*key, ignore=carried) is None]
    reached = 0
    for location, position in [*(key for key in free if key != home), home]:
        drive_to(world, location)
        done = world.put_down(location, position)
        where = world.placement(carried)
        if done.ok and (where.location, where.position, where.resting) == (location, position, True):
            reached += 1
        else:
            problems.append(f"{carried} on {location} / {position}: {done.failure} (gap {done.gap_m:.2f} m)")
        if world.holding is None and not world.pick(carried).ok:
            problems.append(f"cannot pick {carried} again at {location} / {position}")
            break
    return reached, len(free), problems
