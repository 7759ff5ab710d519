"""The scripted planner's planning problem: move objects towards goals, from what it believes.

The planner believes where the robot is, what it holds, each location's place positions and their
occupants, where each object it saw is (on a place position, or standing loose at a location) and
the map's hops. A goal puts an object on a place position of a location (a given one, or any). The
objects that may move are the goal objects, those resting on a position a goal names (or on a
location too full for the objects "anywhere" there) and the one in the hand; the others stay put.
A state is (the robot's location, the held mover, each mover's spot, the open containers); move_to,
grab, place and open cost one action each, and a move also costs the map hops it drives: the
one A* search (`robocog.agent.symbolic.search`) finds the fewest actions, then the fewest hops.

Containers (furniture that opens) are as in the generator's problem (`robocog.agent.symbolic.plans`):
the positions at a container's location are inside it, reachable only while it is open, and opening
or closing needs the hand free. A closed container hides its positions and contents, so the belief
may know neither: an object the task says is inside (`expected`) stands somewhere at its location,
and a closed container whose positions were never seen is given one position, `UNSEEN` (the plan
opens it before it could place there, and the look after opening shows the real ones).

This module reads the belief and the goals through small protocols (what the planner's `Belief` and
`Goal` offer), so it imports nothing of the planner. A goal is met in the sense of the shared
conditions (`robocog.shared.tasks.rests_at`: an at_location or at_position condition).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence, Set
from dataclasses import dataclass
from typing import Any, Protocol

from robocog.agent.symbolic.bounds import drives_along
from robocog.agent.symbolic.search import Cost, Problem, astar
from robocog.shared.tasks import rests_at

#: The search by (actions, hops) gives up after expanding this many states; the search by actions
#: alone then gets `FEWEST_ACTIONS_LIMIT` (and when it gives up too, the planner fails honestly).
SEARCH_LIMIT = 50_000
FEWEST_ACTIONS_LIMIT = 400_000
#: Map hops charged for a move between locations with no known path.
NO_PATH_HOPS = 99

Spot = tuple[str, str | None]  # (location, place position); no position: somewhere at the location
HELD: Spot = ("", None)
#: the robot's location, the held mover, each mover's spot, the open containers
State = tuple[str, int | None, tuple[Spot, ...], frozenset[str]]
#: The position believed inside a closed container whose positions were never seen.
UNSEEN = "(inside)"
Action = tuple[str, dict[str, str]]  # (tool, arguments): move_to, grab, place or open
#: What the estimate of a state counts whatever the robot's location (`Rearrangement._spots_estimate`).
_SpotsEstimate = tuple[int, frozenset[str], tuple[tuple[str, str], ...], str | None]


class Target(Protocol):
    """Where a goal wants an object: a location, and a place position of it (None: any)."""

    @property
    def location(self) -> str: ...

    @property
    def position(self) -> str | None: ...


class Believed(Protocol):
    """What the planner believes of the world (its `Belief`)."""

    @property
    def location(self) -> str: ...

    @property
    def holding(self) -> str | None: ...

    @property
    def positions(self) -> Mapping[str, list[str]]: ...

    @property
    def occupant(self) -> Mapping[tuple[str, str], str | None]: ...

    @property
    def where(self) -> Mapping[str, Spot]: ...

    @property
    def containers(self) -> Mapping[str, str]: ...

    @property
    def closed(self) -> Set[str]: ...

    @property
    def expected(self) -> Mapping[str, str]: ...

    def hops_from(self, start: str) -> dict[str, int]: ...

    def hop_table(self, starts: Iterable[str]) -> dict[str, dict[str, int]]: ...


def satisfied(spot: Spot | None, goal: Target) -> bool:
    """Whether an object at `spot` meets `goal` (it rests on the goal's position, or on any of its
    location's when the goal names none)."""
    return rests_at(spot, goal.location, goal.position)


@dataclass(frozen=True)
class Rearrangement:
    """The problem: the objects that may move (`movers`) and where each should end."""

    movers: tuple[str, ...]
    goals: tuple[Target | None, ...]  # per mover; None: it only has to clear a position a goal names
    fixed: frozenset[tuple[str, str]]  # positions held by objects that stay put
    positions: Mapping[str, list[str]]
    stops: tuple[str, ...]  # the locations worth driving to
    hops: dict[str, dict[str, int]]
    named: frozenset[Spot]  # the positions the goals name
    anywhere: tuple[str, ...]  # the locations of goals "anywhere at L"
    boxes: Mapping[str, tuple[str, ...]]  # location -> the containers there (its positions are inside)

    def key(self) -> Any:
        """The problem as a hashable value (for the plan cache)."""
        return (
            self.movers,
            self.goals,
            self.fixed,
            tuple((loc, tuple(ps)) for loc, ps in sorted(self.positions.items())),
            self.stops,
            tuple((loc, tuple(sorted(h.items()))) for loc, h in sorted(self.hops.items())),
            self.named,
            self.anywhere,
            tuple((loc, b) for loc, b in sorted(self.boxes.items())),
        )

    def done(self, state: State) -> bool:
        """Every goal met, the hand empty."""
        _, held, spots, _ = state
        return held is None and all(g is None or satisfied(s, g) for s, g in zip(spots, self.goals, strict=True))

    def estimate(self, state: State) -> Cost:
        """A lower bound on what is left: (actions, map hops). Actions: a grab and a place per object
        out of place, and the drives: to every location still to visit, and those that carrying the
        objects with goals elsewhere needs (`robocog.agent.symbolic.bounds`); hops: the drive to the
        farthest of those locations."""
        here, held, spots, _ = state
        known = self._estimates.get((held, spots))
        if known is None:  # the search reaches the same spots from many locations (one per drive)
            known = self._estimates[held, spots] = self._spots_estimate(held, spots)
        actions, visit, moves, target = known
        if target is not None and target != here:  # the held object, carried from here
            moves = tuple(sorted((*moves, (here, target))))
        hops = self.hops[here]
        drives = max(drives_along(moves, here), len(visit) - (here in visit))
        return actions + drives, max([hops.get(loc, 0) for loc in visit], default=0)

    def _spots_estimate(self, held: int | None, spots: tuple[Spot, ...]) -> _SpotsEstimate:
        """What `estimate` counts whatever the robot's location: the actions, the locations to visit,
        the objects to carry but the held one (as `robocog.agent.symbolic.bounds.drives_along` takes
        them) and where the held object must go (None: held is None, or it has no goal)."""
        named = self.named
        actions = 2 * sum(self._to_clear(held, spots, loc) for loc in self.anywhere)
        visit: set[str] = set()
        edges: list[tuple[str, str]] = []  # (where it lies, where it must go) per object to carry
        target: str | None = None
        for i, (spot, goal) in enumerate(zip(spots, self._targets, strict=True)):
            if held == i:
                actions += 1
                if goal is not None:
                    visit.add(goal[0])
                    target = goal[0]
            elif goal is None:
                if spot in named:
                    actions += 2
                    visit.add(spot[0])
            elif not rests_at(spot, *goal):  # `satisfied`
                actions += 2
                visit.add(spot[0])
                visit.add(goal[0])
                edges.append((spot[0], goal[0]))
        return actions, frozenset(visit), tuple(sorted(e for e in edges if e[0] != e[1])), target

    @functools.cached_property
    def _estimates(self) -> dict[tuple[int | None, tuple[Spot, ...]], _SpotsEstimate]:
        """`_spots_estimate` by what it reads (a problem is searched once: this lives as long as the
        search)."""
        return {}

    @functools.cached_property
    def _targets(self) -> tuple[tuple[str, str | None] | None, ...]:
        """Per mover, its goal's location and position (None: no goal)."""
        return tuple(None if g is None else (g.location, g.position) for g in self.goals)

    @functools.cached_property
    def _arrivals(self) -> dict[str, tuple[int, ...]]:
        """Per location of goals "anywhere" there, the movers with such a goal."""
        return {
            loc: tuple(i for i, g in enumerate(self.goals) if g is not None and g.location == loc and not g.position)
            for loc in self.anywhere
        }

    @functools.cached_property
    def _room(self) -> dict[str, tuple[Spot, ...]]:
        """Per location of goals "anywhere" there, its positions that no goal names and nothing fixed
        holds."""
        taken = self.named | self.fixed
        return {
            loc: tuple((loc, p) for p in self.positions.get(loc, []) if (loc, p) not in taken) for loc in self.anywhere
        }

    def _to_clear(self, held: int | None, spots: tuple[Spot, ...], location: str) -> int:
        """How many objects with no goal must at least leave `location` to make room for the objects
        still to arrive "anywhere" there."""
        arriving = sum(1 for i in self._arrivals[location] if held == i or spots[i][0] != location)
        if not arriving:
            return 0
        by_spot = dict(zip(spots, self.goals, strict=True))
        room = 0
        for spot in self._room[location]:
            if spot not in by_spot:  # a free position
                room += 1
                continue
            goal = by_spot[spot]
            room += goal is not None and not satisfied(spot, goal)
        return max(0, arriving - room)

    def successors(self, state: State) -> Iterator[tuple[Action, State, Cost]]:
        """(action, next state, (1, map hops driven)) for each action worth considering."""
        here, held, spots, opened = state
        boxes = self.boxes.get(here, ())
        shut = any(box not in opened for box in boxes)  # the positions here are out of reach
        if held is None and not shut:
            for i, spot in enumerate(spots):
                if spot != HELD and spot[0] == here:
                    grabbed = (here, i, (*spots[:i], HELD, *spots[i + 1 :]), opened)
                    yield ("grab", {"object": self.movers[i]}), grabbed, (1, 0)
        elif held is not None and not shut:
            taken = self.fixed | {s for s in spots if s[1]}
            for position in self.positions.get(here, []):
                if (here, position) not in taken:
                    put = (*spots[:held], (here, position), *spots[held + 1 :])
                    yield ("place", {"location": here, "position": position}), (here, None, put, opened), (1, 0)
        if held is None:
            for box in boxes:
                if box not in opened:
                    yield ("open", {"furniture": box}), (here, held, spots, opened | {box}), (1, 0)
        hops = self.hops[here]
        for stop in self.stops:
            if stop != here:
                moved = (stop, held, spots, opened)
                yield ("move_to", {"location": stop}), moved, (1, hops.get(stop, NO_PATH_HOPS))


def rearrangement(belief: Believed, goals: Mapping[str, Target]) -> tuple[Rearrangement, State] | None:
    """The problem and its start state; None when a goal object is nowhere to be seen (or expected),
    or a goal's location has no place position known (not seen yet, under partial observation)."""
    expected = {o: (belief.containers[b], None) for o, b in belief.expected.items() if b in belief.containers}
    where: dict[str, Spot] = {**expected, **belief.where}
    if any(o not in where and o != belief.holding for o in goals):
        return None
    positions = dict(belief.positions)
    for box in belief.closed:
        location = belief.containers.get(box)
        if location is not None and not positions.get(location):
            positions[location] = [UNSEEN]
    if any(not positions.get(g.location) for g in goals.values()):
        return None
    named = {(g.location, g.position) for g in goals.values() if g.position}
    anywhere = {g.location for g in goals.values() if not g.position}
    cleared = named | {(loc, p) for loc in anywhere if _short_of_room(belief, goals, loc) for p in positions[loc]}
    blockers = [o for spot in cleared if (o := belief.occupant.get(spot)) is not None and o not in goals and o in where]
    holding = belief.holding
    held = [holding] if holding and holding not in goals else []
    movers = tuple(dict.fromkeys([*goals, *sorted(blockers), *held]))
    fixed = frozenset(spot for spot, o in belief.occupant.items() if o is not None and o not in movers)
    spots = tuple(HELD if o == belief.holding else where[o] for o in movers)
    stops = {loc for loc, names in positions.items() if names} | {s[0] for s in spots if s[0]}
    stops |= {g.location for g in goals.values()}
    everywhere = belief.hop_table(stops | {belief.location})
    boxes: dict[str, tuple[str, ...]] = {}
    for box, location in sorted(belief.containers.items()):
        boxes[location] = (*boxes.get(location, ()), box)
    problem = Rearrangement(
        movers,
        tuple(goals.get(o) for o in movers),
        fixed,
        positions,
        tuple(sorted(stops)),
        everywhere,
        frozenset(named),
        tuple(sorted(anywhere)),
        boxes,
    )
    held_index = movers.index(belief.holding) if belief.holding else None
    opened = frozenset(b for b in belief.containers if b not in belief.closed)
    return problem, (belief.location, held_index, spots, opened)


def _short_of_room(belief: Believed, goals: Mapping[str, Target], location: str) -> bool:
    """Whether the goals "anywhere at `location`" outnumber its positions free or held by goal objects
    (then the other objects there may have to make room)."""
    wanted = sum(1 for g in goals.values() if g.location == location and not g.position)
    room = [p for p in belief.positions.get(location, []) if belief.occupant.get((location, p)) in (None, *goals)]
    return wanted > len(room)


def optimal_plan(belief: Believed, goals: Mapping[str, Target]) -> list[Action] | None:
    """The fewest move_to/grab/place actions that meet every goal and leave the hand empty (among
    those, the plan driving the fewest map hops); None when there is none (or the search gives up).
    Objects that no goal names move only to clear a position a goal names.

    Fewest actions always; fewest hops among them where the search can rank every tie within
    `SEARCH_LIMIT` expansions (else the first plan of the fewest actions it finds).

    The planner asks again every turn, from the state its last action led to: a plan found once is
    remembered for each state along it (the rest of an optimal plan is optimal from there), so an
    episode searches once, not once a turn."""
    found = rearrangement(belief, goals)
    if found is None:
        return None
    problem, start = found
    key = problem.key()
    known = _PLANS.get((key, start))
    if known is not None:
        return list(known)
    result = astar(
        Problem(start, problem.successors, problem.done, problem.estimate),
        expansion_limit=SEARCH_LIMIT,
        deeper_first=True,
    )
    if result is None:  # too many plans tie on actions to rank them all by hops (a whole house to tidy)
        result = astar(
            Problem(start, _actions_only(problem.successors), problem.done, lambda s: (problem.estimate(s)[0], 0)),
            expansion_limit=FEWEST_ACTIONS_LIMIT,
            deeper_first=True,
        )
    if result is None:
        return None
    _remember(key, problem, start, result.actions)
    return result.actions


def _actions_only(
    successors: Callable[[State], Iterator[tuple[Action, State, Cost]]],
) -> Callable[[State], Iterator[tuple[Action, State, Cost]]]:
    """The same successors with the map hops left out of their cost: the search that still finds the
    fewest actions when ranking the ties among them by hops would search too long."""

    def fewest_actions(state: State) -> Iterator[tuple[Action, State, Cost]]:
        for action, nxt, cost in successors(state):
            yield action, nxt, (cost[0], 0)

    return fewest_actions


#: Plans found, by (problem, state): what is left of a plan from each state along it.
_PLANS: dict[tuple[Any, State], tuple[Action, ...]] = {}
_PLANS_KEPT = 20_000


def _remember(key: Any, problem: Rearrangement, start: State, plan: Sequence[Action]) -> None:
    if len(_PLANS) > _PLANS_KEPT:
        _PLANS.clear()
    state = start
    for i, action in enumerate(plan):
        _PLANS[(key, state)] = tuple(plan[i:])
        state = next(nxt for step, nxt, _ in problem.successors(state) if step == action)
    _PLANS[(key, state)] = ()
