"""The semantic map: named locations joined by edges, A* over it, and forgiving name lookup."""

from __future__ import annotations

import difflib
import heapq
import math
import re

from robocog.shared.scene import Scene


def normalise(name: str) -> str:
    """Case, spaces, hyphens and underscores do not matter in names given by a model."""
    return re.sub(r"[\s_\-]+", " ", name).strip().casefold()


def resolve(name: str, known: list[str]) -> str | None:
    """The known name `name` stands for (exact up to `normalise`), or None."""
    wanted = normalise(name)
    for candidate in known:
        if normalise(candidate) == wanted:
            return candidate
    return None


def closest(name: str, known: list[str], n: int = 3) -> list[str]:
    """Known names close to `name`, best first (for 'did you mean' messages)."""
    by_norm = {normalise(k): k for k in known}
    matches = difflib.get_close_matches(normalise(name), list(by_norm), n=n, cutoff=0.4)
    wanted = normalise(name)
    # Also offer names that contain the word(s) given, e.g. "shelf" -> "Kitchen Shelf".
    contains = [k for nk, k in by_norm.items() if wanted and (wanted in nk or nk in wanted)]
    out: list[str] = []
    for k in [by_norm[m] for m in matches] + contains:
        if k not in out:
            out.append(k)
    return out[:n]


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
