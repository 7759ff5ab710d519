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
from collections import Counter
from collections.abc import Iterable


def carrying_drives(edges: Iterable[tuple[str, str]], here: str) -> int:
    """The fewest drives that carry one object along each edge (from, to), from the robot at `here`.
    (A search asks for few distinct edge sets over many states: the answers are cached.)"""
    return _carrying_drives(tuple(sorted((a, b) for a, b in edges if a != b)), here)


@functools.lru_cache(maxsize=65_536)
def _carrying_drives(moves: tuple[tuple[str, str], ...], here: str) -> int:
    if not moves:
        return 0
    parent: dict[str, str] = {}

    def root(v: str) -> str:
        while parent.setdefault(v, v) != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    surplus: Counter[str] = Counter()
    for a, b in moves:
        parent[root(a)] = root(b)
        surplus[a] += 1
        surplus[b] -= 1
    trails: Counter[str] = Counter()
    for v in parent:
        trails[root(v)] += max(0, surplus[v])
    count = sum(max(1, trails[r]) for r in {root(v) for v in parent})
    starts_here = any(a == here for a, _ in moves)
    return len(moves) + count - 1 + (0 if starts_here else 1)
