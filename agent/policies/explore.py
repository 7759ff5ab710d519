"""What the planner does about what it cannot see: containers to open, and objects to search for.

A closed container (drawer, cabinet, fridge) hides what is inside and keeps the hand out, and opening
it needs the hand free. The planner's plan opens what it needs (`robocog.agent.symbolic.rearrangement`
knows containers as the generator's optimum does, `robocog.agent.symbolic.plans`); this module tells
it what it cannot see: a goal object the task says is inside a closed container ("take the X out of
the drawer") is expected there (`ground`). Once every goal is met, the planner closes what the task
asks it to close (the last place put the robot at that container: one action, as in the optimum).

Under partial observation the task may name an object the robot has not seen ("Find the X and bring
it to L"). Then it explores: looks around wherever it has not looked, and drives to the nearest (by
map hops over the map it knows so far) location it has not seen or closed container it has not
opened, opening each to look inside, until it has seen every goal object and every goal location;
then it plans as usual. An object found before its destination has been seen goes along in the hand
(the destination's name is known from a neighbour's look, or the search goes on). When nothing is
left to search and an object is still missing, it says so.
It leaves the containers it opened open: only a task that asks it to close one is helped by closing.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from robocog.agent.policies.belief import Belief, Goal, Request
from robocog.agent.symbolic.rearrangement import satisfied
from robocog.shared.names import name_key


@dataclass(frozen=True)
class Move:
    """The next tool call (`tool` None: stop, the task cannot be done, for `reason`)."""

    tool: str | None
    arguments: dict[str, Any] = field(default_factory=dict)
    reason: str = ""


def known_names(belief: Belief) -> list[str]:
    """Every location the belief knows by name: seen, or named as a neighbour of one seen."""
    names = dict.fromkeys([*belief.neighbours, *(n for ns in belief.neighbours.values() for n in ns)])
    return list(dict.fromkeys([*names, *belief.containers.values()]))


def _lookup(name: str, options: Iterable[str]) -> str:
    """The option `name` names (compared as names are: `robocog.shared.names.name_key`), else `name`."""
    key = name_key(name)
    return next((o for o in options if name_key(o) == key), name)


def ground(request: Request, belief: Belief) -> Request:
    """The request with its goal objects and locations spelled as the belief knows them, where it knows
    them (a reader writes what the prompt says of what the first look did not show); a goal object not
    seen that the request says is in a closed container is noted in the belief as expected there."""
    objects, places = belief.objects(), known_names(belief)
    goals = {_lookup(o, objects): _spelled(g, places, belief) for o, g in request.goals.items()}
    unseen = [o for o in goals if o not in objects]
    for box in request.look_in:
        if box in belief.closed:
            belief.expected.update({o: box for o in unseen})
    return replace(request, goals=goals)


def _spelled(goal: Goal, places: list[str], belief: Belief) -> Goal:
    """A goal's location as the belief spells it; a place read whole before it was seen ("kitchen counter
    left") split into a location and one of its positions once the location is known."""
    location = _lookup(goal.location, places)
    if location in places or goal.position is not None:
        return replace(goal, location=location)
    head, _, last = goal.location.rpartition(" ")
    known = _lookup(head, places) if head else head
    positions = {name_key(p): p for p in belief.positions.get(known, [])}
    if known in places and name_key(last) in positions:
        return Goal(known, positions[name_key(last)])
    return replace(goal, location=location)


def next_move(request: Request, goals: Mapping[str, Goal], belief: Belief) -> Move | None:
    """The next call about containers or the search, or None when the plan of carrying can go on."""
    if belief.location not in belief.seen or belief.location in belief.recheck:
        return Move("look_around")  # partial observation: a new place is unknown until looked at
    free = belief.holding is None
    missing = [o for o in goals if o not in belief.where and o != belief.holding and o not in belief.expected]
    unseen = [g.location for g in goals.values() if g.location not in belief.seen]
    if not missing and unseen:  # everything found, a destination not seen yet
        return _towards(belief, goals, unseen, free)
    if missing:
        return _search(belief, missing, unseen, free)
    done = all(satisfied(belief.where.get(o), g) for o, g in goals.items())
    to_close = next((b for b in request.close if b not in belief.closed), None)
    if done and free and to_close is not None:
        return _at(belief, belief.containers.get(to_close, belief.location), Move("close", {"furniture": to_close}))
    return None


def room_to_work(belief: Belief) -> Move | None:
    """When no plan fits the part of the house seen so far (no free position to park an object that
    must make room): the nearest location not seen yet, which may have one; None when all is seen."""
    nearest = _nearest(belief, set())
    return None if nearest is None else Move("move_to", {"location": nearest})


def _towards(belief: Belief, goals: Mapping[str, Goal], unseen: list[str], free: bool) -> Move:
    """With every goal object found and a destination not seen: take along a goal object standing
    here (the hand free), then drive to the destination when the map names it, else search on."""
    here = [o for o, g in goals.items() if belief.where.get(o, ("", None))[0] == belief.location]
    if free and here:
        return Move("grab", {"object": here[0]})
    known = [loc for loc in unseen if loc in known_names(belief)]
    return Move("move_to", {"location": known[0]}) if known else _search(belief, [], unseen, free)


def _at(belief: Belief, location: str, then: Move) -> Move:
    """`then`, after driving to `location` if the robot is elsewhere."""
    return then if belief.location == location else Move("move_to", {"location": location})


def _search(belief: Belief, missing: list[str], unseen: list[str], free: bool) -> Move:
    """Towards the nearest place that may show what is missing: a closed container (with the hand
    free, while an object is missing) or a location not seen yet."""
    boxes = {loc for box, loc in belief.containers.items() if box in belief.closed} if missing and free else set()
    if belief.location in boxes:
        here = next(b for b, loc in sorted(belief.containers.items()) if loc == belief.location and b in belief.closed)
        return Move("open", {"furniture": here})
    nearest = _nearest(belief, boxes)
    if nearest is not None:
        return Move("move_to", {"location": nearest})
    lost = [f"the {o}" for o in missing] + [f"a place called '{loc}'" for loc in unseen]
    return Move(None, reason=f"I searched every location and container and did not find {' or '.join(lost)}.")


def _nearest(belief: Belief, also: set[str]) -> str | None:
    """The nearest location (by map hops, then name) not seen yet, or one of `also`; None when none."""
    hops = _hops(belief)
    again = belief.recheck - {belief.location}
    places = sorted((loc for loc in hops if loc not in belief.seen or loc in also | again), key=lambda n: (hops[n], n))
    return places[0] if places else None


def _hops(belief: Belief) -> dict[str, int]:
    """Map hops from the robot to every location it knows a way to (through locations seen)."""
    dist = {belief.location: 0}
    queue = deque([belief.location])
    while queue:
        node = queue.popleft()
        for nxt in belief.neighbours.get(node, []) if node in belief.seen else []:
            if nxt not in dist:
                dist[nxt] = dist[node] + 1
                queue.append(nxt)
    return dist
