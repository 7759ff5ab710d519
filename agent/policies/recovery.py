"""How the scripted planner recovers when the world changes under it (`robocog.shared.perturbations`).

The planner sees what a model sees: the tool results' text (never their `_meta`). From it this
module reads the setbacks of the episode (`read_setbacks`) and tells the planner:

- when to look around again (`look_again`): after a result that says "Something changed: ...", or
  after a robot action that failed for a reason its belief cannot account for (a place with an empty
  hand after a silent slip, a blocked corridor, a grab that found nothing);
- how to drive round a corridor it knows is blocked (`detour`): hop by hop along the fewest-hops
  route that avoids it, when there is one (until it learns the corridor is clear); otherwise it
  drives as before, so a block that has lifted lets it through (a look around in between lets the
  calls, and so the block's time, pass);
- what to give up on (`lost`): a goal whose location (or whose object) it cannot reach after
  `MAX_BLOCKED` blocked drives, an object it cannot see anywhere, or one that lies where the arm
  does not reach. The planner then empties its hand and ends the task honestly, with failure.
"""

from __future__ import annotations

import functools
import itertools
import re
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field

from robocog.agent.families.reading import Goal
from robocog.agent.policies.belief import Belief
from robocog.agent.policies.history import Call, PastCall
from robocog.agent.policies.sightings import closed_over

#: What the server appends to a result when an announced perturbation happened.
CHANGED = "Something changed:"
#: Blocked drives in an episode before the planner gives up on what it cannot reach.
MAX_BLOCKED = 4
#: Grabs of one object that failed where it lies before the planner gives up on it.
MAX_GRAB_MISSES = 2

_BLOCKED = re.compile(r"The way from (.+?) to (.+?) is blocked")
#: What a blocked drive's result says of a block that never clears (robocog-v2.1).
_FOR_GOOD = "It will not clear"
_BLOCK_NEWS = re.compile(r"The way between (.+?) and (.+?) is blocked\.")
_CLEAR_NEWS = re.compile(r"The way between (.+?) and (.+?) is clear again\.")
#: Failures the planner's belief already accounts for (it gives up, or marks the position taken).
_UNDERSTOOD = frozenset({"not_graspable", "unknown_object", "position_occupied", "place_failed"})
_ACTIONS = frozenset({"move_to", "grab", "place"})

Corridor = frozenset[str]


@dataclass(frozen=True)
class Setbacks:
    """What went wrong so far in the episode, as the results told it."""

    blocked: frozenset[Corridor]  # corridors believed blocked now
    blocked_drives: int  # move_to calls that stopped before a block
    misses: Mapping[str, int]  # object -> grabs that failed where the planner believed it lay
    unseen: frozenset[str]  # objects a grab said are near no location
    grabbed: frozenset[str]  # objects the hand held at some point of the episode
    out_of_reach: Mapping[tuple[str, str, str], int] = field(default_factory=dict)  # (object, location,
    # position) -> places that failed there because the arm could not reach, standing at the location
    for_good: frozenset[Corridor] = frozenset()  # corridors the world said will not clear


def _message(call: PastCall) -> str:
    return str((call.result or {}).get("message", ""))


@functools.lru_cache(maxsize=4096)
def _news(text: str) -> tuple[tuple[tuple[str, str], ...], tuple[tuple[str, str], ...]]:
    """The corridors a result's text says are blocked, and those it says are clear again (the planner
    reads every result again each turn: the answers are remembered)."""
    return tuple(_BLOCK_NEWS.findall(text)), tuple(_CLEAR_NEWS.findall(text))


def read_setbacks(calls: list[PastCall]) -> Setbacks:
    """The episode's setbacks, from its tool results in order."""
    blocked: set[Corridor] = set()
    drives = 0
    misses: dict[str, int] = {}
    unseen: set[str] = set()
    grabbed: set[str] = set()
    missed_places: dict[tuple[str, str, str], int] = {}
    for_good: set[Corridor] = set()
    for call in calls:
        text, result = _message(call), call.result or {}
        blocks, clears = _news(text)
        for a, b in blocks:
            blocked.add(frozenset((a, b)))
        for a, b in clears:
            blocked.discard(frozenset((a, b)))
        if call.name == "move_to":
            stop = _BLOCKED.search(text) if result.get("status") == "failure" else None
            if stop is not None:
                blocked.add(frozenset(stop.groups()))
                drives += 1
                if _FOR_GOOD in text:
                    for_good.add(frozenset(stop.groups()))
            path = result.get("path") or []
            for a, b in itertools.pairwise(path):
                blocked.discard(frozenset((a, b)))  # driven through: clear
        if call.name == "grab" and result.get("error") == "out_of_reach":
            obj = str(call.arguments.get("object", ""))
            if "not near any location" in text:
                unseen.add(obj)
            elif "move_to(" not in text:
                misses[obj] = misses.get(obj, 0) + 1
        if (
            call.name == "place"
            and result.get("error") == "out_of_reach"
            and "move_to(" not in text
            and not closed_over(result)
        ):
            key = (
                str(result.get("object", "")),
                str(call.arguments.get("location")),
                str(call.arguments.get("position")),
            )
            missed_places[key] = missed_places.get(key, 0) + 1
        if call.name == "grab" and result.get("status") == "success":
            misses.pop(str(call.arguments.get("object", "")), None)
            grabbed.add(str(call.arguments.get("object", "")))
    blocked |= for_good
    return Setbacks(
        frozenset(blocked), drives, misses, frozenset(unseen), frozenset(grabbed), missed_places, frozenset(for_good)
    )


def look_again(calls: list[PastCall]) -> bool:
    """Whether the last result asks for a fresh look around: it carries news of a change, or it is a
    failed robot action the belief does not account for."""
    if not calls or calls[-1].name == "look_around":
        return False
    last = calls[-1]
    if CHANGED in _message(last):
        return True
    failed = last.result is not None and last.result.get("status") == "failure"
    return last.name in _ACTIONS and failed and last.result is not None and last.result.get("error") not in _UNDERSTOOD


def surprised(calls: list[PastCall]) -> bool:
    """The planner would look again because the world surprised it: news of a change, or a robot action
    that failed (not the look into a container it has just opened, nor the first look)."""
    last = calls[-1] if calls else None
    return last is not None and (look_again(calls) or (last.is_error and last.name != "open"))


def _route(belief: Belief, start: str, goal: str, avoid: frozenset[Corridor]) -> list[str] | None:
    """The fewest-hops route on the believed map from `start` to `goal` not using `avoid`."""
    came: dict[str, str | None] = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        if node == goal:
            path = [node]
            while (prev := came[path[-1]]) is not None:
                path.append(prev)
            return path[::-1]
        for nxt in belief.neighbours.get(node, []):
            if nxt not in came and frozenset((node, nxt)) not in avoid:
                came[nxt] = node
                queue.append(nxt)
    return None


def detour(call: Call, belief: Belief, setbacks: Setbacks) -> Call:
    """While a corridor is believed blocked, a move_to as the first hop of the fewest-hops route that
    avoids every such corridor (the server drives its own shortest route, which may cross one), when
    there is such a route; any other call, or a move_to with no way round, as it is."""
    target = call.arguments.get("location")
    if call.name != "move_to" or not setbacks.blocked or not isinstance(target, str):
        return call
    around = _route(belief, belief.location, target, setbacks.blocked)
    if around is None or len(around) < 2:
        return call  # no way round: drive as before (the block may have lifted)
    return type(call)("move_to", {"location": around[1]})


def lost(goals: Mapping[str, Goal], belief: Belief, setbacks: Setbacks) -> dict[str, str]:
    """The goal objects the planner gives up on, and why: out of sight (a grab said so, or it left the
    hand and no look has seen it since), out of the arm's reach where they lie or where they must go
    (places there failed so, twice), or (after
    `MAX_BLOCKED` blocked drives) beyond a corridor that stays blocked."""
    out: dict[str, str] = {}
    for obj, goal in goals.items():
        if belief.holding == obj:
            places = [goal.location]
        elif obj in setbacks.unseen or (obj in setbacks.grabbed and obj not in belief.where):  # fell out of sight
            out[obj] = "it is nowhere to be seen"
            continue
        elif setbacks.misses.get(obj, 0) >= MAX_GRAB_MISSES:
            out[obj] = "it lies out of the arm's reach"
            continue
        if goal.position and setbacks.out_of_reach.get((obj, goal.location, goal.position), 0) >= MAX_GRAB_MISSES:
            out[obj] = f"the arm cannot reach {goal.location} / {goal.position} with it"
            continue
        else:  # where it lies, if it has been seen (a search has not found it yet)
            places = [belief.where[obj][0], goal.location] if obj in belief.where else [goal.location]
        cut_off = [
            p for p in places if setbacks.for_good and _route(belief, belief.location, p, setbacks.for_good) is None
        ]
        if cut_off:  # the world said the way will not clear, and there is no other
            ways = ", ".join(sorted(" - ".join(sorted(c)) for c in setbacks.for_good))
            out[obj] = f"the way to {cut_off[0]} is blocked for good ({ways})"
            continue
        if setbacks.blocked_drives < MAX_BLOCKED:
            continue
        stuck = [p for p in places if _route(belief, belief.location, p, setbacks.blocked) is None]
        if stuck:
            ways = ", ".join(sorted(" - ".join(sorted(c)) for c in setbacks.blocked))
            out[obj] = f"the way to {stuck[0]} stayed blocked ({ways})"
    return out
