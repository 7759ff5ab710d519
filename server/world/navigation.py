"""The semantic map: named locations joined by edges, A* over it, and forgiving name lookup."""

from __future__ import annotations

import difflib
import heapq
import math

from robocog.shared.names import ARTICLES, name_key
from robocog.shared.scene import Scene


def normalise(name: str) -> str:
    """Case, spaces, hyphens, underscores and surrounding punctuation do not matter in names given by
    a model (`robocog.shared.names.name_key`, every article kept)."""
    return name_key(name, articles="keep")


def resolve(name: str, known: list[str]) -> str | None:
    """The known name `name` stands for (exact up to `normalise`), or None."""
    wanted = normalise(name)
    for candidate in known:
        if normalise(candidate) == wanted:
            return candidate
    return None


#: Words that never tell names apart: articles (`ARTICLES`) are dropped, and these do not count as overlap.
_FILLER = ARTICLES | {"of", "to", "in", "on", "at", "into", "onto", "my", "your"}
#: How similar a whole name must be to count as a misspelling ("Kitchen Shelve", "cub").
NAME_CUTOFF = 0.75
#: How similar one word must be to count as the same word ("shelve" for "shelf"); words of at least 3 letters.
WORD_CUTOFF = 0.7


def strip_articles(name: str) -> str:
    """`name` normalised, without 'the', 'a' and 'an' (`robocog.shared.names.name_key`)."""
    return name_key(name, articles="all")


def _similar(a: str, b: str) -> float:
    return difflib.SequenceMatcher(None, a, b).ratio()


def _same_word(word: str, other: str) -> bool:
    return word == other or (min(len(word), len(other)) >= 3 and _similar(word, other) >= WORD_CUTOFF)


def closest(name: str, known: list[str], n: int = 3) -> list[str]:
    """Known names `name` plausibly stands for, best first (for 'did you mean' messages).

    Articles do not matter ("the shelf"). A close misspelling of a whole name is offered first
    ("Kitchen Shelve", "cub"); otherwise the names sharing the most words with `name` ("shelf" ->
    "Kitchen Shelf"; a misspelt word counts: "shelve"). Never a name that merely has some letters
    in common ("table" is not "cube").
    """
    wanted = strip_articles(name)
    if not wanted:
        return []
    words = [w for w in wanted.split() if w not in _FILLER]
    scored: list[tuple[float, int, int, str]] = []
    for index, candidate in enumerate(known):
        norm = normalise(candidate)
        overlap = sum(1 for w in words if any(_same_word(w, t) for t in norm.split()))
        scored.append((_similar(wanted, norm), overlap, index, candidate))
    kept = [s for s in scored if s[0] >= NAME_CUTOFF]
    if not kept:
        best = max((s[1] for s in scored), default=0)
        kept = [s for s in scored if best > 0 and s[1] == best]
    kept.sort(key=lambda s: (-s[0], -s[1], s[2]))
    return [s[3] for s in kept[:n]]


class SemanticMap:
    """Locations as graph nodes with (x, y); edges weighted by Euclidean distance."""

    def __init__(self, scene: Scene) -> None:
        self.points: dict[str, tuple[float, float]] = {loc.name: (loc.x, loc.y) for loc in scene.locations}
        self.neighbours: dict[str, list[str]] = {name: [] for name in self.points}
        for a, b in scene.edges:
            if b not in self.neighbours[a]:
                self.neighbours[a].append(b)
            if a not in self.neighbours[b]:
                self.neighbours[b].append(a)

    @property
    def names(self) -> list[str]:
        return list(self.points)

    def distance(self, a: str, b: str) -> float:
        (ax, ay), (bx, by) = self.points[a], self.points[b]
        return math.hypot(ax - bx, ay - by)

    def shortest_path(self, start: str, goal: str) -> list[str] | None:
        """A* with the straight-line heuristic; None when the goal cannot be reached."""
        if start == goal:
            return [start]
        frontier: list[tuple[float, float, str]] = [(self.distance(start, goal), 0.0, start)]
        came_from: dict[str, str] = {}
        cost = {start: 0.0}
        while frontier:
            _, g, node = heapq.heappop(frontier)
            if node == goal:
                path = [node]
                while node in came_from:
                    node = came_from[node]
                    path.append(node)
                return path[::-1]
            if g > cost[node]:
                continue
            for nxt in self.neighbours[node]:
                new_cost = g + self.distance(node, nxt)
                if new_cost < cost.get(nxt, math.inf):
                    cost[nxt] = new_cost
                    came_from[nxt] = node
                    heapq.heappush(frontier, (new_cost + self.distance(nxt, goal), new_cost, nxt))
        return None

    def nearest(self, x: float, y: float) -> tuple[str, float]:
        """The location closest to (x, y) and its distance."""
        name = min(self.points, key=lambda n: math.hypot(self.points[n][0] - x, self.points[n][1] - y))
        px, py = self.points[name]
        return name, math.hypot(px - x, py - y)
