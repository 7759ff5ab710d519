"""The invariants of a world's ground truth, as a client reads it (`robocog://world/state`): checked
after every hostile call by the fuzz test and the stdio fuzz."""

from __future__ import annotations

from collections import Counter

from robocog.shared.results import WorldState


def broken_invariants(state: WorldState, objects: list[str], locations: list[str]) -> list[str]:
    """What is wrong with the world's ground truth: objects lost or made up, a position holding two
    objects, more than one object held, a held object resting on a position, a robot off the map."""
    problems: list[str] = []
    names = sorted(o.object for o in state.objects)
    if names != objects:
        problems.append(f"objects not conserved: {names} instead of {objects}")
    resting = Counter((o.location, o.position) for o in state.objects if o.state == "on_position")
    problems += [f"{where} holds {n} objects" for where, n in resting.items() if n > 1]
    listed = Counter((p.location, p.position) for p in state.positions)
    problems += [f"position {where} listed {n} times" for where, n in listed.items() if n > 1]
    placements = {o.object: o for o in state.objects}
    for p in state.positions:
        if p.occupied_by is None:
            continue
        o = placements.get(p.occupied_by)
        if o is None or o.state != "on_position" or (o.location, o.position) != (p.location, p.position):
            problems.append(f"{p.location}/{p.position} says {p.occupied_by} but the object says {o}")
    held = [o.object for o in state.objects if o.state == "held"]
    if len(held) > 1:
        problems.append(f"{len(held)} objects held: {held}")
    if state.robot.holding != (held[0] if held else None):
        problems.append(f"the robot holds {state.robot.holding} but the objects held are {held}")
    if state.robot.holding is not None and state.robot.holding in {p.occupied_by for p in state.positions}:
        problems.append(f"{state.robot.holding} is held and placed at once")
    if state.robot.location not in locations:
        problems.append(f"the robot is at {state.robot.location!r}, not on the map")
    return problems
