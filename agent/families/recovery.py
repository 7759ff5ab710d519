"""Recovery: a transport task during which one thing goes wrong (`assets/families/recovery.yaml`).

Each draw picks an item and a location as bring's does (`bring.item_elsewhere`), then one
perturbation (`robocog.shared.perturbations`) the symbolic world can justify, announced or silent
(seeded, even odds):

- `slip`: the item slips out of the hand during the first drive with it;
- `moved`: someone moves the item to a free floor position (drawn here: not the item's location, the
  goal's or the robot's start) at the robot's first move_to, while it is on its way;
- `blocked`: a corridor of the route the robot drives (the shortest one in metres, as the server's
  A*) is blocked, from the call that drives it, for two to four calls;
- `blocked_for_good`: a corridor every route from the item to the goal needs is blocked from the
  first call and never clears: the task cannot be done (an honest failure is the success).

The calls are counted as the server counts them (every robot tool call since the reset); an agent
that, like the scripted planner, searches its memory, looks around and writes its plan first makes
its first move_to at call `FIRST_MOVE`. Its prompts are transport prompts, read by bring's reader.
"""

from __future__ import annotations

import heapq
import itertools
import math
import random
from typing import Any

from robocog.agent.families.bring import item_elsewhere, other_location
from robocog.agent.families.containers import CONTAINER_EXAMPLE, item_into_container
from robocog.agent.families.registry import draw
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant
from robocog.shared.scene import Scene

#: The robot tool call of an agent's first move_to after search_memory, look_around and its plan note.
FIRST_MOVE = 4
#: A block that clears lasts this many calls (fewest, most).
BLOCK_CALLS = (2, 4)
#: A block that never clears (the most a perturbation may last).
FOREVER = 1000

_EXAMPLE: dict[str, Any] = {"item": "mug", "location": "Front Door", "perturbations": []}


def neighbours(scene: Scene) -> dict[str, list[str]]:
    """Each location's neighbours on the scene's map (scene order)."""
    out: dict[str, list[str]] = {loc.name: [] for loc in scene.locations}
    for a, b in scene.edges:
        out[a].append(b)
        out[b].append(a)
    return out


def route(scene: Scene, start: str, goal: str, without: frozenset[str] | None = None) -> list[str] | None:
    """The shortest path in metres from `start` to `goal` (as the server's A* drives it), not using
    the corridor `without`; None when there is none."""
    points = {loc.name: (loc.x, loc.y) for loc in scene.locations}
    near = neighbours(scene)
    best: dict[str, float] = {start: 0.0}
    came: dict[str, str] = {}
    frontier = [(0.0, start)]
    while frontier:
        cost, node = heapq.heappop(frontier)
        if node == goal:
            path = [node]
            while path[-1] in came:
                path.append(came[path[-1]])
            return path[::-1]
        if cost > best[node]:
            continue
        for nxt in near[node]:
            if without is not None and frozenset((node, nxt)) == without:
                continue
            step = cost + math.dist(points[node], points[nxt])
            if step < best.get(nxt, math.inf):
                best[nxt], came[nxt] = step, node
                heapq.heappush(frontier, (step, nxt))
    return None


def _transport(rng: random.Random, world: SceneNames, where: Where) -> tuple[str, str, str] | None:
    """An item resting away from the robot's start, where it rests, and a location with a free place
    position to bring it to: its optimal plan is move_to, grab, move_to, place (nothing to clear first),
    so the first object in the hand is the item and the calls of its drives are known."""
    item, spot, location = item_elsewhere(rng, world, where)
    if spot is None or location is None or spot[0] == world.scene.robot_start:
        return None
    if all(s in where.values() for s in world.spots_at(location)):
        return None
    return item, spot[0], location


def _announce(rng: random.Random) -> bool:
    return rng.random() < 0.5


@draw("slip_in_transport", gives=_EXAMPLE)
def slip_in_transport(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, which slips out of the hand during the first drive with it."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, _, location = found
    slip = {"kind": "slip", "on_drive": 1, "announce": _announce(rng)}
    return {"item": item, "location": location, "perturbations": [slip]}


@draw("moved_in_transport", gives=_EXAMPLE)
def moved_in_transport(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, which someone moves to a free floor position while the robot is on its way."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, at, location = found
    taken = set(where.values())
    away = {at, location, world.scene.robot_start}
    floors = [
        (p.location, p.name)
        for p in world.scene.place_positions
        if p.support == "floor" and p.location not in away and (p.location, p.name) not in taken
    ]
    if not floors:
        return None
    to = rng.choice(floors)
    moved = {"kind": "move_object", "object": item, "to": list(to), "at_call": FIRST_MOVE, "announce": _announce(rng)}
    return {"item": item, "location": location, "perturbations": [moved]}


@draw("blocked_in_transport", gives=_EXAMPLE)
def blocked_in_transport(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, and a corridor of the robot's route blocked for a few calls from the call that
    drives it (to the item: the first move_to; with it: the move_to after the grab)."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, at, location = found
    scene = world.scene
    to_item, to_goal = route(scene, scene.robot_start, at), route(scene, at, location)
    if to_item is None or to_goal is None:
        return None
    legs = [(FIRST_MOVE, a, b) for a, b in itertools.pairwise(to_item)]
    legs += [(FIRST_MOVE + 2, a, b) for a, b in itertools.pairwise(to_goal)]
    call, a, b = rng.choice(legs)
    block = {
        "kind": "block_edge",
        "edge": [a, b],
        "at_call": call,
        "duration": rng.randint(*BLOCK_CALLS),
        "announce": _announce(rng),
    }
    return {"item": item, "location": location, "perturbations": [block]}


@draw("blocked_for_good", gives=_EXAMPLE)
def blocked_for_good(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, and a corridor every route from it to the goal needs, blocked for good from
    the first call: the task cannot be done."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, at, location = found
    scene = world.scene
    path = route(scene, at, location)
    if path is None:
        return None
    bridges = [(a, b) for a, b in itertools.pairwise(path) if route(scene, at, location, frozenset((a, b))) is None]
    if not bridges:
        return None
    a, b = rng.choice(bridges)
    block = {"kind": "block_edge", "edge": [a, b], "at_call": 1, "duration": FOREVER, "announce": _announce(rng)}
    return {"item": item, "location": location, "perturbations": [block]}


# --- robocog-v2.1: set off by the world's state, not by a count of calls -------------------------------
#
# Whatever order an agent calls its tools in, each of these happens before its goal can be reached and
# changes what it must do: the item is moved as the robot sets off towards it (`when: approach`); a
# corridor every route needs is blocked as the robot sets off on a drive that needs it (`when: route`),
# for a few calls or for good; a container the robot opened is closed behind it as it drives away to
# fetch what goes in (`when: leave`). No perturbation puts anything on a position something occupies.


def bridges(scene: Scene, start: str, goal: str) -> list[tuple[str, str]]:
    """The corridors of the route from `start` to `goal` that every route between them needs."""
    path = route(scene, start, goal)
    if path is None:
        return []
    return [(a, b) for a, b in itertools.pairwise(path) if route(scene, start, goal, frozenset((a, b))) is None]


@draw("moved_on_approach", gives=_EXAMPLE)
def moved_on_approach(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, in the robot's own room (so the first look shows it, even when a look shows only
    the room), which someone moves to a free floor position in another room as the robot sets off
    towards it (not the goal's location, nor the robot's start). An item the agent never saw could be
    moved into a room it had already searched, and nothing it is told would say so: the move must
    take away what the agent knows."""
    start = world.scene.robot_start
    here = [
        o
        for o in world.graspable
        if (s := where[o]) is not None and s[0] != start and world.room_of(s[0]) == world.room_of(start)
    ]
    if not here:
        return None
    item = rng.choice(here)
    at = (where[item] or ("", ""))[0]
    location = other_location(rng, world, at)
    if location is None or all(s in where.values() for s in world.spots_at(location)):
        return None
    taken = set(where.values())
    away = {location, world.scene.robot_start}
    floors = [
        (p.location, p.name)
        for p in world.scene.place_positions
        if p.support == "floor"
        and p.location not in away
        and world.room_of(p.location) != world.room_of(at)
        and (p.location, p.name) not in taken
        and (p.location, p.name) in world.spots
    ]
    if not floors:
        return None
    to = rng.choice(floors)
    moved = {"kind": "move_object", "object": item, "to": list(to), "when": "approach", "announce": _announce(rng)}
    return {"item": item, "location": location, "perturbations": [moved]}


@draw("blocked_on_route", gives=_EXAMPLE)
def blocked_on_route(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring, and a corridor every route to the item (or from it to the goal) needs, blocked
    for two to four calls as the robot sets off on a drive through it."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, at, location = found
    scene = world.scene
    legs = bridges(scene, scene.robot_start, at) + bridges(scene, at, location)
    if not legs:
        return None
    a, b = rng.choice(legs)
    block = {
        "kind": "block_edge",
        "edge": [a, b],
        "when": "route",
        "duration": rng.randint(*BLOCK_CALLS),
        "announce": _announce(rng),
    }
    return {"item": item, "location": location, "perturbations": [block]}


@draw("blocked_for_good_on_route", gives=_EXAMPLE)
def blocked_for_good_on_route(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to bring behind a corridor every route to it needs, blocked for good as the robot sets off
    through it: the task cannot be done, and the first drive towards the item shows it."""
    found = _transport(rng, world, where)
    if found is None:
        return None
    item, at, location = found
    legs = bridges(world.scene, world.scene.robot_start, at)
    if not legs:
        return None
    a, b = rng.choice(legs)
    block = {"kind": "block_edge", "edge": [a, b], "when": "route", "duration": FOREVER, "announce": _announce(rng)}
    return {"item": item, "location": location, "perturbations": [block]}


@draw("closed_on_leaving", gives={"item": "mug", "shut": ["kitchen_fridge"], **CONTAINER_EXAMPLE})
def closed_on_leaving(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item to put into a container (closed, as all are at the start) that stands elsewhere, so the
    robot must open the container with its hand free and drive away to fetch the item: someone closes
    the container behind it as it goes, and it finds it shut when it comes back with the item."""
    params = item_into_container(rng, world, where, v)
    if params is None:
        return None
    box = params["shut"][0]
    at = where.get(params["item"])
    home = next(c.location for c in world.scene.containers if c.name == box)
    if at is None or at[0] == home:
        return None
    shut = {"kind": "close_container", "container": box, "when": "leave", "announce": _announce(rng)}
    return {**params, "perturbations": [shut]}
