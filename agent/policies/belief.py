"""The scripted planner's belief about the world: where it has seen each object, which places are
open, the house's map as the tools describe it. `robocog.agent.policies.history` builds it from the
conversation; `robocog.agent.policies.sightings` updates it with each look.
"""

from __future__ import annotations

import functools
import re
from collections import deque
from collections.abc import Hashable, Iterable
from dataclasses import dataclass, field, replace
from typing import Any

from robocog.agent.families.reading import Goal as Goal
from robocog.agent.families.reading import Request as Request

UNGRASPABLE_NOTE = "Objects that cannot be grasped:"
_SEEN = re.compile(r"\bSeen: (.+?)\.(?:\s|$)")
_LOOK = re.compile(r"([\w\- ]+?) \(([^()]*)\)")


def seen_looks(message: str) -> dict[str, tuple[str, ...]]:
    """What a look_around message says each object looks like ("Seen: mug (white, small), ..."; robocog-v2.1)."""
    said = _SEEN.search(message)
    if said is None:
        return {}
    return {m.group(1).strip(): tuple(w.strip() for w in m.group(2).split(",")) for m in _LOOK.finditer(said.group(1))}


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
    containers: dict[str, str] = field(default_factory=dict)  # furniture that opens -> its location
    closed: set[str] = field(default_factory=set)  # the containers believed closed
    seen: set[str] = field(default_factory=set)  # the locations whose contents a look around showed
    expected: dict[str, str] = field(default_factory=dict)  # object not seen -> the closed container it is in
    looks: dict[str, tuple[str, ...]] = field(default_factory=dict)  # object -> its colour and size, as said
    partial: bool = False  # look_around shows only part of the house
    first_seen: dict[str, tuple[str, str | None]] = field(default_factory=dict)  # object -> where first seen
    recheck: set[str] = field(default_factory=set)  # locations seen before something vanished: look again

    @classmethod
    def from_look(cls, look: dict[str, Any]) -> Belief:
        b = cls(location=look.get("location", ""), holding=look.get("holding"), partial=bool(look.get("observed")))
        b.looks = seen_looks(str(look.get("message", "")))
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
            b.seen.add(name)
        b.first_seen = dict(b.where)
        for box in look.get("furniture", []):
            b.containers[box["name"]] = box["location"]
            if box.get("state") == "closed":
                b.closed.add(box["name"])
        return b

    def copy(self) -> Belief:
        """A belief of its own to change (its map's lists are shared: they are replaced, never changed)."""
        return replace(
            self,
            occupant=dict(self.occupant),
            where=dict(self.where),
            containers=dict(self.containers),
            closed=set(self.closed),
            seen=set(self.seen),
            expected=dict(self.expected),
            looks=dict(self.looks),
            first_seen=dict(self.first_seen),
            recheck=set(self.recheck),
        )

    def hops_from(self, start: str) -> dict[str, int]:
        """Breadth-first distances on the map."""
        return self.hop_table([start])[start]

    def hop_table(self, starts: Iterable[str]) -> dict[str, dict[str, int]]:
        """`hops_from` each of `starts` (a map's distances are remembered: `_hops`)."""
        known = tuple((loc, tuple(near)) for loc, near in self.neighbours.items())
        return {start: dict(_hops(known, start)) for start in starts}

    def free_positions(self, location: str) -> list[str]:
        return [p for p in self.positions.get(location, []) if self.occupant.get((location, p)) is None]

    def objects(self) -> list[str]:
        """Every object seen, the held one included."""
        return list(self.where) + ([self.holding] if self.holding and self.holding not in self.where else [])

    def key(self) -> Hashable:
        """Everything believed, as a hashable value (equal for beliefs alike in every field, in the
        same order)."""
        return (
            self.location,
            self.holding,
            tuple((loc, tuple(near)) for loc, near in self.neighbours.items()),
            tuple((loc, tuple(names)) for loc, names in self.positions.items()),
            tuple(self.occupant.items()),
            tuple(self.where.items()),
            self.stale,
            tuple(self.containers.items()),
            tuple(self.closed),
            tuple(self.seen),
            tuple(self.expected.items()),
            tuple(self.looks.items()),
            self.partial,
            tuple(self.first_seen.items()),
            tuple(sorted(self.recheck)),
        )


@functools.lru_cache(maxsize=4096)
def _hops(neighbours: tuple[tuple[str, tuple[str, ...]], ...], start: str) -> dict[str, int]:
    """Breadth-first distances from `start` on a map (its locations' neighbours, in order)."""
    near = dict(neighbours)
    dist = {start: 0}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for nxt in near.get(node, ()):
            if nxt not in dist:
                dist[nxt] = dist[node] + 1
                queue.append(nxt)
    return dist
