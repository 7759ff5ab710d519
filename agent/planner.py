"""A deterministic symbolic planner that plays the part of a model.

It is stateless like an LLM: each turn it reads the conversation (the task, and every tool call
with its result), rebuilds what it believes about the world, and decides the next tool call. So it
runs through exactly the same agent loop as any model (see `robocog.agent.providers`).

It searches its episodic memory, looks around, writes its plan on the scratchpad, then rearranges
objects greedily (nearest first, over the semantic map from look_around), recovers from failures
(an occupied position: take a free one; something held: put it down first; an object that cannot
be grasped: drop it from the plan and remember it), verifies with a last look, and ends with a
truthful report. Task families: put items away into a location (T1), swap two items (T2), bring an
item to a location. Anything else gets an honest end_task failure.

Variants, as instruments for validating the evaluation: `overconfident` sometimes (seeded
probability) forgets one object and reports success without checking; `refuser` never acts.
"""

from __future__ import annotations

import json
import random
import re
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Literal

Variant = Literal["planner", "overconfident", "refuser"]

#: The planner gives up (honestly) after this many tool calls in one episode.
MAX_TOOL_CALLS = 80

UNGRASPABLE_NOTE = "Objects that cannot be grasped:"


@dataclass(frozen=True)
class Call:
    """The next tool call the planner wants, or a plain text answer when `name` is None."""

    name: str | None
    arguments: dict[str, Any] = field(default_factory=dict)
    text: str = ""


@dataclass(frozen=True)
class Goal:
    location: str
    position: str | None = None  # None: any free position of the location


@dataclass
class Belief:
    """What the planner believes, from its last look around and the results since."""

    location: str = ""
    holding: str | None = None
    neighbours: dict[str, list[str]] = field(default_factory=dict)
    positions: dict[str, list[str]] = field(default_factory=dict)  # location -> position names, in order
    occupant: dict[tuple[str, str], str | None] = field(default_factory=dict)
    where: dict[str, tuple[str, str | None]] = field(default_factory=dict)  # object -> (location, position)
    stale: bool = False

    @classmethod
    def from_look(cls, look: dict[str, Any]) -> Belief:
        b = cls(location=look.get("location", ""), holding=look.get("holding"))
        for loc in look.get("locations", []):
            name = loc["name"]
            b.neighbours[name] = list(loc.get("neighbours", []))
            b.positions[name] = [p["name"] for p in loc.get("place_positions", [])]
            for p in loc.get("place_positions", []):
                b.occupant[(name, p["name"])] = p.get("occupied_by")
                if p.get("occupied_by"):
                    b.where[p["occupied_by"]] = (name, p["name"])
            for obj in loc.get("objects", []):
                b.where.setdefault(obj, (name, None))
        return b

    def copy(self) -> Belief:
        return Belief(
            self.location,
            self.holding,
            self.neighbours,
            self.positions,
            dict(self.occupant),
            dict(self.where),
            self.stale,
        )

    def hops_from(self, start: str) -> dict[str, int]:
        """Breadth-first distances on the map."""
        dist = {start: 0}
        queue = deque([start])
        while queue:
            node = queue.popleft()
            for nxt in self.neighbours.get(node, []):
                if nxt not in dist:
                    dist[nxt] = dist[node] + 1
                    queue.append(nxt)
        return dist

    def free_positions(self, location: str) -> list[str]:
        return [p for p in self.positions.get(location, []) if self.occupant.get((location, p)) is None]


@dataclass
class History:
    """The episode so far, read from the conversation."""

    task: str
    calls: list[tuple[str, dict[str, Any], dict[str, Any] | None, bool]]  # name, args, result, is_error
    memories: list[dict[str, Any]]


# --- reading the conversation --------------------------------------------------------------------


def as_dict(message: Any) -> dict[str, Any]:
    if isinstance(message, dict):
        return message
    if hasattr(message, "model_dump"):
        return message.model_dump()
    return dict(message)


def _parse_json(text: Any) -> dict[str, Any] | None:
    if isinstance(text, list):  # content blocks
        text = "".join(b.get("text", "") for b in text if isinstance(b, dict))
    if not isinstance(text, str):
        return None
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) else None


def read_history(messages: list[Any]) -> History:
    msgs = [as_dict(m) for m in messages]
    task = next((str(m.get("content") or "") for m in msgs if m.get("role") == "user"), "")
    results: dict[str, Any] = {m.get("tool_call_id"): m.get("content") for m in msgs if m.get("role") == "tool"}
    calls: list[tuple[str, dict[str, Any], dict[str, Any] | None, bool]] = []
    memories: list[dict[str, Any]] = []
    for m in msgs:
        if m.get("role") != "assistant":
            continue
        for tc in m.get("tool_calls") or []:
            tc = as_dict(tc)
            fn = as_dict(tc.get("function") or {})
            args = _parse_json(fn.get("arguments") or "{}") or {}
            result = _parse_json(results.get(tc.get("id")))
            is_error = result is None or result.get("status") == "failure"
            calls.append((str(fn.get("name")), args, result, is_error))
            if fn.get("name") == "search_memory" and result:
                memories.extend(result.get("results", []))
    return History(task=task, calls=calls, memories=memories)


def current_belief(history: History) -> tuple[Belief | None, Belief | None]:
    """(belief at the first look around, belief now) — None before any look around."""
    first: Belief | None = None
    belief: Belief | None = None
    for name, args, result, is_error in history.calls:
        if name == "look_around" and result and not is_error:
            belief = Belief.from_look(result)
            first = first or belief.copy()
            continue
        if belief is None or result is None:
            continue
        if name == "move_to":
            belief.location = result.get("location", belief.location)
        elif name == "grab" and not is_error:
            obj = result.get("object") or args.get("object")
            where = belief.where.pop(obj, None)
            if where and where[1]:
                belief.occupant[where] = None
            belief.holding = obj
        elif name == "grab" and result.get("error") == "out_of_reach":
            belief.stale = True  # not where it was believed to be: look again
        elif name == "place" and not is_error:
            key = (result["location"], result["position"])
            belief.occupant[key] = result.get("object")
            belief.where[result.get("object")] = key
            belief.holding = None
        elif name == "place" and result.get("error") == "position_occupied":
            key = (result.get("location"), result.get("position"))
            if belief.occupant.get(key) is None:
                belief.occupant[key] = "(something)"
        elif name == "place" and result.get("error") == "place_failed":
            belief.holding = None
            belief.stale = True
    return first, belief


# --- understanding the task ----------------------------------------------------------------------


def _match_location(text: str, locations: list[str]) -> str | None:
    """The location named in `text`: a full name, else the one whose last word is mentioned."""
    low = text.lower()
    for name in sorted(locations, key=len, reverse=True):
        if name.lower() in low:
            return name
    words = set(re.findall(r"[a-z]+", low))
    hits = [n for n in locations if n.lower().split()[-1] in words]
    return hits[0] if len(hits) == 1 else (sorted(hits, key=len)[0] if hits else None)


def _match_object(word: str, objects: list[str]) -> str | None:
    w = word.lower().rstrip("s")
    return next((o for o in objects if o.lower() == word.lower() or o.lower() == w), None)


def remembered_ungraspable(memories: list[dict[str, Any]]) -> set[str]:
    found: set[str] = set()
    for m in memories:
        match = re.search(re.escape(UNGRASPABLE_NOTE) + r"\s*([\w ,\-]+)\.", m.get("summary", ""))
        if match:
            found.update(x.strip() for x in match.group(1).split(",") if x.strip())
    return found


def understand(task: str, first: Belief, avoid: set[str]) -> tuple[str, dict[str, Goal]] | None:
    """(family, goals) for the task, or None when the planner does not know how."""
    low = task.lower()
    objects = list(first.where) + ([first.holding] if first.holding else [])
    locations = list(first.neighbours)
    swap = re.search(r"\bswap\b\s+(?:the\s+)?([\w\-]+)\s+and\s+(?:the\s+)?([\w\-]+)", low)
    if swap:
        a, b = (_match_object(w, objects) for w in swap.groups())
        if a and b and all(first.where.get(o, (None, None))[1] for o in (a, b)):
            (la, pa), (lb, pb) = first.where[a], first.where[b]
            return "swap", {a: Goal(lb, pb), b: Goal(la, pa)}
        return None
    if re.search(r"\bput\b.*\baway\b|\btidy\b|\bclear\b.*\baway\b", low):
        target = _match_location(re.split(r"\b(?:into|in|onto|on|to)\b", low, maxsplit=1)[-1], locations)
        if target is None:
            return None
        items = [o for o in objects if o not in avoid and first.where.get(o, (None,))[0] != target]
        return "put_away", {o: Goal(target) for o in items}
    bring = re.search(
        r"\b(?:bring|take|move|put|place|carry)\s+(?:the\s+)?([\w\-]+)\s+(?:to|on|onto|into|in)\s+(.+)", low
    )
    if bring:
        obj = _match_object(bring.group(1), objects)
        target = _match_location(bring.group(2), locations)
        if obj and target:
            position = next(
                (p for p in first.positions.get(target, []) if re.search(rf"\b{p}\b", bring.group(2))), None
            )
            return "bring", {obj: Goal(target, position)}
    return None


# --- deciding --------------------------------------------------------------------------------------


def _satisfied(belief: Belief, obj: str, goal: Goal) -> bool:
    where = belief.where.get(obj)
    return bool(where and where[0] == goal.location and where[1] and (goal.position in (None, where[1])))


def _target_position(belief: Belief, goal: Goal, reserved: set[tuple[str, str]]) -> str | None:
    if goal.position is not None:
        return goal.position if belief.occupant.get((goal.location, goal.position)) is None else None
    free = [p for p in belief.free_positions(goal.location) if (goal.location, p) not in reserved]
    return free[0] if free else None


def _parking(belief: Belief, reserved: set[tuple[str, str]]) -> tuple[str, str] | None:
    """The nearest free position that no pending goal needs."""
    hops = belief.hops_from(belief.location)
    for loc in sorted(hops, key=lambda n: (hops[n], n)):
        for p in belief.free_positions(loc):
            if (loc, p) not in reserved:
                return loc, p
    return None


def next_action(belief: Belief, goals: dict[str, Goal], skip: set[str]) -> Call | None:
    """The next action towards the goals, or None when every goal holds."""
    pending = {o: g for o, g in goals.items() if o not in skip and not _satisfied(belief, o, g)}
    reserved = {(g.location, g.position) for g in pending.values() if g.position}
    if belief.holding is not None:
        held = belief.holding
        goal = pending.get(held)
        spot: tuple[str, str] | None = None
        if goal is not None:
            pos = _target_position(belief, goal, reserved - {(goal.location, goal.position or "")})
            spot = (goal.location, pos) if pos else None
        spot = spot or _parking(belief, reserved)
        if spot is None:
            return None
        if belief.location != spot[0]:
            return Call("move_to", {"location": spot[0]})
        return Call("place", {"location": spot[0], "position": spot[1]})
    if not pending:
        return None
    hops = belief.hops_from(belief.location)
    unknown = [o for o in pending if o not in belief.where]
    if unknown:
        return Call("look_around")
    ready = [o for o, g in pending.items() if _target_position(belief, g, reserved - {(g.location, g.position or "")})]
    if ready:
        choice = min(ready, key=lambda o: (hops.get(belief.where[o][0], 99), list(goals).index(o)))
    else:
        # Every goal is taken. A goal held by an object with no goal of its own: clear that one away.
        blockers = [
            b
            for g in pending.values()
            if g.position
            and (b := belief.occupant.get((g.location, g.position))) not in (None, *pending)
            and b in belief.where
        ]
        pool = blockers or list(pending)
        choice = min(pool, key=lambda o: (hops.get(belief.where[o][0], 99), o not in goals, o))
    where = belief.where[choice][0]
    if belief.location != where:
        return Call("move_to", {"location": where})
    return Call("grab", {"object": choice})


def _summary(
    task: str,
    belief: Belief,
    goals: dict[str, Goal],
    skip: set[str],
    ungraspable: set[str],
    n: int,
    why: dict[str, str] | None = None,
) -> str:
    done = [
        f"the {o} is on {belief.where[o][0]} / {belief.where[o][1]}"
        for o in goals
        if o in belief.where and belief.where[o][1]
    ]
    parts = [f"Task: {task}", ("Result: " + "; ".join(done) + ".") if done else "Nothing was moved."]
    if ungraspable:
        parts.append(f"{UNGRASPABLE_NOTE} {', '.join(sorted(ungraspable))}.")
    missed = sorted(o for o in skip if o not in ungraspable)
    if missed:
        reasons = why or {}
        parts.append(
            "Could not finish: " + "; ".join(f"{o} ({reasons[o]})" if o in reasons else o for o in missed) + "."
        )
    parts.append(f"It took {n} tool calls.")
    return " ".join(parts)


def decide(messages: list[Any], variant: Variant = "planner", *, seed: int | None = None, p: float = 0.3) -> Call:
    """The planner's next move for the conversation so far."""
    history = read_history(messages)
    task = history.task.strip()
    if variant == "refuser":
        return Call(None, text="I believe this task has already been completed, so there is nothing left to do.")
    calls = [c[0] for c in history.calls]
    if "search_memory" not in calls:
        return Call("search_memory", {"query": task})
    if "look_around" not in calls:
        return Call("look_around")
    first, belief = current_belief(history)
    if first is None or belief is None:  # look_around failed: nothing to plan on
        return Call(
            "end_task", {"status": "failure", "description": task, "summary": "I could not perceive the world."}
        )
    avoid = remembered_ungraspable(history.memories)
    understood = understand(task, first, avoid)
    if understood is None:
        return Call(
            "end_task",
            {
                "status": "failure",
                "description": task,
                "summary": "I do not know how to do this task. I can put items away into a location, swap two "
                "items, and bring an item to a location.",
            },
        )
    family, goals = understood
    sloppy = variant == "overconfident" and random.Random(f"{seed}:{task}").random() < p
    if "add_to_scratchpad" not in calls:
        plan = "; ".join(f"{o} -> {g.location}" + (f" / {g.position}" if g.position else "") for o, g in goals.items())
        note = f" Known not graspable: {', '.join(sorted(avoid))}." if avoid else ""
        return Call("add_to_scratchpad", {"text": f"Plan ({family}) for '{task}': {plan}.{note}"})
    ungraspable = {
        a.get("object") for n, a, r, _ in history.calls if n == "grab" and r and r.get("error") == "not_graspable"
    }
    ungraspable |= avoid & set(goals)
    unreachable_objects = {
        a.get("object") for n, a, r, _ in history.calls if n == "grab" and r and r.get("error") == "unknown_object"
    }
    skip = {o for o in ungraspable | unreachable_objects if o}
    # A goal "anywhere at L" with no free position at L cannot be met: give it up, honestly.
    full = {
        o
        for o, g in goals.items()
        if g.position is None and not _satisfied(belief, o, g) and not belief.free_positions(g.location)
    }
    # Putting things away, the planner learns by trying whether an object can be grasped at all;
    # one it has held and cannot place stays where it put it back.
    held_before = {
        a.get("object") for n, a, r, _ in history.calls if n == "grab" and r and r.get("status") == "success"
    }
    full = {o for o in full if family != "put_away" or o in held_before}
    skip |= {o for o in full if o != belief.holding}
    why = {o: f"no free place position at {goals[o].location}" for o in full}
    why |= {o: "no such object" for o in unreachable_objects if o}
    if len(history.calls) >= MAX_TOOL_CALLS:
        summary = _summary(task, belief, goals, skip | set(goals), ungraspable, len(history.calls) + 1, why)
        return Call("end_task", {"status": "failure", "description": task, "summary": summary})
    if belief.stale:
        return Call("look_around")
    if sloppy and goals:
        # The overconfident instrument skips the object it would have started with, and will
        # report success without checking.
        hops = first.hops_from(first.location)
        skip = skip | {min(goals, key=lambda o: (hops.get(first.where.get(o, ("",))[0], 99), list(goals).index(o)))}
    action = next_action(belief, goals, skip)
    if action is not None:
        return action
    # Every goal holds in belief: check with a last look (unless sloppy), then report truthfully.
    if not sloppy and calls[-1] != "look_around":
        return Call("look_around")
    achieved = all(_satisfied(belief, o, g) for o, g in goals.items() if o not in skip)
    if sloppy:
        summary = _summary(task, belief, goals, set(), ungraspable, len(history.calls) + 1)
        return Call("end_task", {"status": "success", "description": task, "summary": summary})
    # Objects that cannot be grasped are not items to put away; for a swap or a bring they are the task.
    gave_up = skip & goals.keys() if family != "put_away" else set()
    status = "success" if (achieved and not gave_up) or sloppy else "failure"
    summary = _summary(task, belief, goals, skip, ungraspable, len(history.calls) + 1, why)
    return Call("end_task", {"status": status, "description": task, "summary": summary})
