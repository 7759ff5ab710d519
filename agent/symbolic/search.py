"""The one optimal search: a deterministic A* over hashable states.

What "optimal" means, everywhere in robocog (the suite generator's `optimal_steps`, the scripted
planner's plans): the fewest robot actions (move_to, grab and place, one each). Where a problem also
counts map hops (the planner does), they break ties between plans of the fewest actions: a cost is a
vector compared lexicographically, its first component the number of actions.

A problem gives a start state, its successors (action, next state, step cost), a goal test and an
estimate of the cost left. The estimate must be admissible (never more than the true cost, component
by component in the lexicographic order) for the plan found to be optimal; when it is also
consistent, every state is expanded at most once. Ties are broken the same way every run: by the
estimated total, then (with `deeper_first`) by the larger cost so far, then by the order in which
states were reached (successors in the order the problem yields them). So the same problem always
gives the same plan.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass
from operator import add
from typing import Generic, TypeVar

S = TypeVar("S", bound=Hashable)  # a state
A = TypeVar("A")  # an action

Cost = tuple[int, ...]  # compared lexicographically; the first component counts actions


@dataclass(frozen=True)
class Found(Generic[S, A]):
    """An optimal plan: its actions in order, the goal state it reaches and what it costs."""

    actions: list[A]
    state: S
    cost: Cost


@dataclass(frozen=True)
class Problem(Generic[S, A]):
    """A search problem over states `S` with actions `A` (see the module's docstring)."""

    start: S
    successors: Callable[[S], Iterable[tuple[A, S, Cost]]]
    is_goal: Callable[[S], bool]
    estimate: Callable[[S], Cost]


def astar(
    problem: Problem[S, A],
    *,
    expansion_limit: int | None = None,
    action_limit: int | None = None,
    deeper_first: bool = False,
) -> Found[S, A] | None:
    """An optimal plan for `problem`, or None when there is none within the limits.

    `expansion_limit`: give up (None) after expanding this many states. `action_limit`: never extend
    a plan beyond this many actions (the first cost component). `deeper_first`: among states of equal
    estimated total, expand the one with more actions so far first."""
    start, successors, is_goal, estimate = problem.start, problem.successors, problem.is_goal, problem.estimate
    zero: Cost = tuple(0 for _ in estimate(start))
    best: dict[S, Cost] = {start: zero}  # the cheapest known way to each state
    came_from: dict[S, tuple[S, A]] = {}
    order = itertools.count()

    def key(state: S, cost: Cost) -> tuple[int, ...]:
        total = tuple(map(add, cost, estimate(state)))
        return (*total, -cost[0], next(order)) if deeper_first else (*total, next(order))

    frontier: list[tuple[tuple[int, ...], S, Cost]] = [(key(start, zero), start, zero)]
    expanded = 0
    while frontier:
        _, state, cost = heapq.heappop(frontier)
        if best[state] != cost:
            continue  # a stale entry: a cheaper way here was found since
        if is_goal(state):
            actions: list[A] = []
            node = state
            while node in came_from:
                node, action = came_from[node]
                actions.append(action)
            return Found(actions[::-1], state, cost)
        if action_limit is not None and cost[0] >= action_limit:
            continue
        expanded += 1
        if expansion_limit is not None and expanded > expansion_limit:
            return None
        for action, nxt, step in successors(state):
            then = tuple(map(add, cost, step))
            known = best.get(nxt)
            if known is None or then < known:
                best[nxt] = then
                came_from[nxt] = (state, action)
                heapq.heappush(frontier, (key(nxt, then), nxt, then))
    return None
