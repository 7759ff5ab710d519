"""A lower bound on the drives a one-handed robot needs to carry objects between locations, shared by
the two A* problems (the suite generator's, `plans`, and the planner's, `rearrangement`).

Each object that must change location is an edge from where it lies to where it must go. With one
hand, every edge needs a drive of its own that carries that object into its target (a *loaded*
drive). Loaded drives chain without a drive in between only when one object's target is where the
next one lies, so the edges fall into trails, and between two trails, or before the first when the
robot stands where no trail can begin, there is at least one more drive. The fewest trails that
cover a directed multigraph's edges are, per weakly connected component, the sum over its vertices
of how many more edges leave than enter (at least one per component); so

    drives >= edges + trails - 1 (+1 when no edge leaves the robot's location).

Ignoring everything else (the order a held object imposes, parking, locations only passed through)
only makes the bound lower, so it stays admissible.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable


def carrying_drives(edges: Iterable[tuple[str, str]], here: str) -> int:
    """The fewest drives that carry one object along each edge (from, to), from the robot at `here`.
    (A search asks for few distinct edge sets over many states: the answers are cached, per edge set
    whatever the robot's location.)"""
    return drives_along(tuple(sorted((a, b) for a, b in edges if a != b)), here)


def drives_along(moves: tuple[tuple[str, str], ...], here: str) -> int:
    """`carrying_drives` for edges already sorted, none from a location to itself."""
    if not moves:
        return 0
    drives, sources = _carrying_drives(moves)
    return drives if here in sources else drives + 1


@functools.lru_cache(maxsize=65_536)
def _carrying_drives(moves: tuple[tuple[str, str], ...]) -> tuple[int, frozenset[str]]:
    """The drives for `moves` from a location where one of them begins, and where they begin."""
    parent: dict[str, str] = {}

    def root(v: str) -> str:
        while (up := parent.setdefault(v, v)) != v:
            parent[v] = parent[up]
            v = parent[v]
        return v

    surplus: dict[str, int] = {}  # per location, the edges that leave it less those that enter it
    for a, b in moves:
        parent[root(a)] = root(b)
        surplus[a] = surplus.get(a, 0) + 1
        surplus[b] = surplus.get(b, 0) - 1
    trails: dict[str, int] = {}  # per component (by its root), the trails that must begin in it
    for v, more in surplus.items():
        r = root(v)
        trails[r] = trails.get(r, 0) + (more if more > 0 else 0)
    count = sum(n if n > 1 else 1 for n in trails.values())
    return len(moves) + count - 1, frozenset(a for a, _ in moves)
