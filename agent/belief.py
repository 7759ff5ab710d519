"""What the scripted planner reads from the conversation: the episode's tool calls, its belief
about the world, and the task's goals.

Like a model, the planner is stateless: every turn it rebuilds all of this from the messages.
"""

from __future__ import annotations

import json
import re
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from robocog.agent.protocols import task_of

UNGRASPABLE_NOTE = "Objects that cannot be grasped:"


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


@dataclass(frozen=True)
class PastCall:
    """A tool call made earlier in the episode, with its result (None when it was not JSON)."""

    name: str
    arguments: dict[str, Any]
    result: dict[str, Any] | None
    is_error: bool


@dataclass
class History:
    """The episode so far, read from the conversation."""

    task: str
    calls: list[PastCall]
    memories: list[dict[str, Any]]


# --- reading the conversation --------------------------------------------------------------------


def as_dict(message: Any) -> dict[str, Any]:
    """A chat message (a dict, or a LiteLLM/pydantic object) as a plain dict."""
    if isinstance(message, dict):
        return message
    if hasattr(message, "model_dump"):
        dumped: dict[str, Any] = message.model_dump()
        return dumped
    return dict(message)


def _parse_json(content: Any) -> dict[str, Any] | None:
    if content is None:
        return None
    try:
        value = json.loads(_plain(content))
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) else None


def _plain(content: Any) -> str:
    """A message's content as text (content blocks joined)."""
    if isinstance(content, list):  # content blocks
        return "".join(str(b.get("text", "")) for b in content if isinstance(b, dict))
    return str(content or "")


def read_history(messages: list[Any]) -> History:
    """The task, every tool call with its result, and the memories found, from the conversation."""
    msgs = [as_dict(m) for m in messages]
    asked = [(i, task_of(_plain(m.get("content")))) for i, m in enumerate(msgs) if m.get("role") == "user"]
    task = asked[-1][1] if asked else ""
    # The current task began at the first of the trailing user messages that carry it: a conversation
    # may hold earlier tasks (the paper's protocol runs T2 after T1 in one conversation).
    begin = 0
    for i, asked_task in reversed(asked):
        if asked_task != task:
            break
        begin = i
    msgs = msgs[begin:]
    results: dict[Any, Any] = {m.get("tool_call_id"): m.get("content") for m in msgs if m.get("role") == "tool"}
    calls: list[PastCall] = []
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
            calls.append(PastCall(str(fn.get("name")), args, result, is_error))
            if fn.get("name") == "search_memory" and result:
                memories.extend(result.get("results", []))
    return History(task=task, calls=calls, memories=memories)


def current_belief(history: History) -> tuple[Belief | None, Belief | None]:
    """(belief at the first look around, belief now) — None before any look around."""
    first: Belief | None = None
    belief: Belief | None = None
    for call in history.calls:
        name, args, result, is_error = call.name, call.arguments, call.result, call.is_error
        if name == "look_around" and result and not is_error:
            belief = Belief.from_look(result)
            first = first or belief.copy()
            continue
        if belief is None or result is None:
            continue
        if name == "move_to":
            belief.location = result.get("location", belief.location)
        elif name == "grab" and not is_error:
            obj: str | None = result.get("object") or args.get("object")
            where = belief.where.pop(obj, None) if obj is not None else None
            if where and where[1]:
                belief.occupant[(where[0], where[1])] = None
            belief.holding = obj
        elif name == "grab" and result.get("error") == "out_of_reach":
            belief.stale = True  # not where it was believed to be: look again
        elif name == "place" and not is_error:
            key = (result["location"], result["position"])
            placed: str | None = result.get("object")
            belief.occupant[key] = placed
            if placed is not None:  # a successful place names the object
                belief.where[placed] = key
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
    """Objects that past task reports say cannot be grasped."""
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
