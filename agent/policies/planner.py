"""A deterministic symbolic planner that plays the part of a model: the suite's oracle.

It is stateless like an LLM: each turn it reads the conversation (the task, and every tool call
with its result), rebuilds what it believes about the world (`robocog.agent.policies.belief`), and decides
the next tool call. So it runs through exactly the same agent loop as any model (see
`robocog.agent.policies.providers`).

It searches its episodic memory, looks around, understands the task as goals (where each object
should end up: objects named by name, by a description or by where they are), and says at once,
honestly, when they cannot be met (no such object, an object it remembers cannot be grasped, more
objects than free place positions). It writes its plan on the scratchpad, then each turn takes the
first step of an optimal plan from what it believes now: an A* search over the symbolic world
(move_to, grab and place cost one each; among the shortest plans, the one that drives the fewest
map hops), which parks an object on a free position when a goal needs it (a swap, a rearrangement).
An object not resting on a place position may be a fixture (the TV): when the task needs it, the
planner tries to grasp it before it moves anything else; "put away all the items" tries such
objects last, as they may not be items at all. It recovers from failures by looking again, verifies
with a last look, and ends with a truthful report, leaving nothing in the hand.

The planner is one policy (`Planner`): `prepare` reads the episode and does the preliminaries,
`act` takes the next step towards the goals, `conclude` verifies and reports. The variants are
wrappers around it, as instruments for validating the evaluation: `Overconfident` sometimes
(seeded probability) forgets one object and reports success without checking; `Refuser` never
acts. `decide` builds the policy for a variant and asks it for the next move.
"""

from __future__ import annotations

import heapq
import itertools
import random
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import Any, Literal, TypeGuard

from robocog.agent.policies.belief import (
    UNGRASPABLE_NOTE,
    Belief,
    Goal,
    History,
    PastCall,
    Request,
    current_belief,
    read_history,
    remembered_ungraspable,
    understand,
)

Variant = Literal["planner", "overconfident", "refuser"]
VARIANTS: tuple[Variant, ...] = ("planner", "overconfident", "refuser")

#: The planner gives up (honestly) after this many tool calls in one episode.
MAX_TOOL_CALLS = 80
#: The plan search gives up after expanding this many states (the planner then fails honestly).
SEARCH_LIMIT = 50_000
#: The robot actions, the steps of a plan.
ROBOT_ACTIONS = ("move_to", "grab", "place")


@dataclass(frozen=True)
class Call:
    """The next tool call the planner wants, or a plain text answer when `name` is None."""

    name: str | None
    arguments: dict[str, Any] = field(default_factory=dict)
    text: str = ""


# --- the optimal plan ------------------------------------------------------------------------------

Spot = tuple[str, str | None]  # (location, place position); no position: somewhere at the location
HELD: Spot = ("", None)
State = tuple[str, int | None, tuple[Spot, ...]]  # the robot's location, the held mover, each mover's spot


@dataclass(frozen=True)
class _Search:
    """The symbolic problem: the objects that may move (`movers`) and where each should end."""

    movers: tuple[str, ...]
    goals: tuple[Goal | None, ...]  # per mover; None: it only has to clear a position a goal names
    fixed: frozenset[tuple[str, str]]  # positions held by objects that stay put
    positions: dict[str, list[str]]
    stops: tuple[str, ...]  # the locations worth driving to
    hops: dict[str, dict[str, int]]
    named: frozenset[Spot]  # the positions the goals name
    anywhere: tuple[str, ...]  # the locations of goals "anywhere at L"


def _satisfied(spot: Spot | None, goal: Goal) -> bool:
    return bool(spot and spot[0] == goal.location and spot[1] and goal.position in (None, spot[1]))


def _search_problem(belief: Belief, goals: dict[str, Goal]) -> tuple[_Search, State] | None:
    """The problem and its start state; None when a goal object is nowhere to be seen."""
    if any(o not in belief.where and o != belief.holding for o in goals):
        return None
    named = {(g.location, g.position) for g in goals.values() if g.position}
    anywhere = {g.location for g in goals.values() if not g.position}
    cleared = named | {
        (loc, p) for loc in anywhere if _short_of_room(belief, goals, loc) for p in belief.positions[loc]
    }
    blockers = [o for spot in cleared if (o := belief.occupant.get(spot)) not in (None, *goals) and o in belief.where]
    held = [belief.holding] if belief.holding and belief.holding not in goals else []
    movers = tuple(dict.fromkeys([*goals, *sorted(blockers), *held]))
    fixed = frozenset(spot for spot, o in belief.occupant.items() if o is not None and o not in movers)
    spots = tuple(HELD if o == belief.holding else belief.where[o] for o in movers)
    stops = {loc for loc, names in belief.positions.items() if names} | {s[0] for s in spots if s[0]}
    stops |= {g.location for g in goals.values()}
    everywhere = {loc: belief.hops_from(loc) for loc in stops | {belief.location}}
    search = _Search(
        movers,
        tuple(goals.get(o) for o in movers),
        fixed,
        belief.positions,
        tuple(sorted(stops)),
        everywhere,
        frozenset(named),
        tuple(sorted(anywhere)),
    )
    held_index = movers.index(belief.holding) if belief.holding else None
    return search, (belief.location, held_index, spots)


def _short_of_room(belief: Belief, goals: dict[str, Goal], location: str) -> bool:
    """Whether the goals "anywhere at `location`" outnumber its positions free or held by goal objects
    (then the other objects there may have to make room)."""
    wanted = sum(1 for g in goals.values() if g.location == location and not g.position)
    room = [p for p in belief.positions.get(location, []) if belief.occupant.get((location, p)) in (None, *goals)]
    return wanted > len(room)


def _done(search: _Search, state: State) -> bool:
    _, held, spots = state
    return held is None and all(g is None or _satisfied(s, g) for s, g in zip(spots, search.goals, strict=True))


def _estimate(search: _Search, state: State) -> tuple[int, int]:
    """A lower bound on what is left: (actions, map hops). Actions: a grab and a place per object out
    of place, and a drive to every location still to visit (at least one per object that must change
    location); hops: the drive to the farthest of those locations."""
    here, held, spots = state
    named = search.named
    actions, drives, visit = 2 * sum(_to_clear(search, state, loc) for loc in search.anywhere), 0, set()
    for i, (spot, goal) in enumerate(zip(spots, search.goals, strict=True)):
        if held == i:
            actions += 1
            if goal is not None:
                visit.add(goal.location)
                drives += goal.location != here
        elif goal is None:
            if spot in named:
                actions += 2
                visit.add(spot[0])
        elif not _satisfied(spot, goal):
            actions += 2
            visit |= {spot[0], goal.location}
            drives += spot[0] != goal.location
    hops = search.hops[here]
    return actions + max(drives, len(visit - {here})), max((hops.get(loc, 0) for loc in visit), default=0)


def _to_clear(search: _Search, state: State, location: str) -> int:
    """How many objects with no goal must at least leave `location` to make room for the objects
    still to arrive "anywhere" there."""
    _, held, spots = state
    arriving = sum(
        1
        for i, (spot, goal) in enumerate(zip(spots, search.goals, strict=True))
        if goal is not None and goal.location == location and not goal.position and (held == i or spot[0] != location)
    )
    if not arriving:
        return 0
    by_spot = {spot: goal for spot, goal in zip(spots, search.goals, strict=True)}
    room = 0
    for position in search.positions.get(location, []):
        spot = (location, position)
        if spot in search.named or spot in search.fixed:
            continue
        goal = by_spot.get(spot, _FREE)
        room += goal is _FREE or (goal is not None and not _satisfied(spot, goal))
    return max(0, arriving - room)


_FREE = Goal("")


def _successors(search: _Search, state: State) -> Iterator[tuple[Call, State, int]]:
    """(action, next state, map hops driven) for each action worth considering."""
    here, held, spots = state
    if held is None:
        for i, spot in enumerate(spots):
            if spot != HELD and spot[0] == here:
                yield Call("grab", {"object": search.movers[i]}), (here, i, (*spots[:i], HELD, *spots[i + 1 :])), 0
    else:
        taken = search.fixed | {s for s in spots if s[1]}
        for position in search.positions.get(here, []):
            if (here, position) not in taken:
                put = (*spots[:held], (here, position), *spots[held + 1 :])
                yield Call("place", {"location": here, "position": position}), (here, None, put), 0
    for stop in search.stops:
        if stop != here:
            yield Call("move_to", {"location": stop}), (stop, held, spots), search.hops[here].get(stop, 99)


def optimal_plan(belief: Belief, goals: dict[str, Goal]) -> list[Call] | None:
    """The shortest sequence of move_to/grab/place that meets every goal and leaves the hand empty
    (among those, the one driving the fewest map hops); None when there is none (or the search
    gives up). Objects that no goal names move only to clear a position a goal names.

    The planner asks again every turn, from the state its last action led to: a plan found once is
    remembered for each state along it (the rest of an optimal plan is optimal from there), so an
    episode searches once, not once a turn."""
    problem = _search_problem(belief, goals)
    if problem is None:
        return None
    search, start = problem
    key = _problem_key(search)
    known = _PLANS.get((key, start))
    if known is not None:
        return list(known)
    plan = _search(search, start)
    if plan is not None:
        _remember(key, search, start, plan)
    return plan


#: Plans found, by (problem, state): what is left of a plan from each state along it.
_PLANS: dict[tuple[Any, State], tuple[Call, ...]] = {}
_PLANS_KEPT = 20_000


def _problem_key(search: _Search) -> Any:
    return (
        search.movers,
        search.goals,
        search.fixed,
        tuple((loc, tuple(ps)) for loc, ps in sorted(search.positions.items())),
        search.stops,
        tuple((loc, tuple(sorted(h.items()))) for loc, h in sorted(search.hops.items())),
        search.named,
        search.anywhere,
    )


def _remember(key: Any, search: _Search, start: State, plan: list[Call]) -> None:
    if len(_PLANS) > _PLANS_KEPT:
        _PLANS.clear()
    state = start
    for i, call in enumerate(plan):
        _PLANS[(key, state)] = tuple(plan[i:])
        state = next(nxt for step, nxt, _ in _successors(search, state) if step == call)
    _PLANS[(key, state)] = ()


def _search(search: _Search, start: State) -> list[Call] | None:
    """A* over the symbolic states from `start` (see `optimal_plan`)."""
    best: dict[State, tuple[int, int]] = {start: (0, 0)}  # (actions, hops) of the best way there
    came_from: dict[State, tuple[State, Call]] = {}
    order = itertools.count()
    frontier = [(*_estimate(search, start), 0, next(order), start, (0, 0))]
    expanded = 0
    while frontier:
        *_, state, cost = heapq.heappop(frontier)
        if best[state] != cost:
            continue  # a stale entry
        if _done(search, state):
            plan: list[Call] = []
            while state in came_from:
                state, call = came_from[state]
                plan.append(call)
            return plan[::-1]
        expanded += 1
        if expanded > SEARCH_LIMIT:
            return None
        for call, nxt, driven in _successors(search, state):
            then = (cost[0] + 1, cost[1] + driven)
            if nxt not in best or then < best[nxt]:
                best[nxt] = then
                came_from[nxt] = (state, call)
                actions, hops = _estimate(search, nxt)
                heapq.heappush(frontier, (then[0] + actions, then[1] + hops, -then[0], next(order), nxt, then))
    return None


def _parking(belief: Belief) -> tuple[str, str] | None:
    """The nearest free place position."""
    hops = belief.hops_from(belief.location)
    for loc in sorted(hops, key=lambda n: (hops[n], n)):
        for p in belief.free_positions(loc):
            return loc, p
    return None


def _go(belief: Belief, location: str, then: Call) -> Call:
    """`then`, after driving to `location` if the robot is elsewhere."""
    return then if belief.location == location else Call("move_to", {"location": location})


# --- the policy ------------------------------------------------------------------------------------

REFUSAL = "I believe this task has already been completed, so there is nothing left to do."
UNKNOWN_TASK = (
    "I do not know how to do this task. I can put items on a location, swap two items, bring an item to a "
    "location or a place position, and arrange items on named place positions."
)


def _end(task: str, status: Literal["success", "failure"], summary: str) -> Call:
    return Call("end_task", {"status": status, "description": task, "summary": summary})


def _grabbed(calls: list[PastCall], key: str, value: str) -> set[str]:
    """The objects of the episode's grab calls whose result has `key` = `value`."""
    return {
        str(c.arguments["object"])
        for c in calls
        if c.name == "grab" and "object" in c.arguments and c.result and c.result.get(key) == value
    }


@dataclass(frozen=True)
class Episode:
    """What the planner has worked out when it is ready to act on the world."""

    task: str
    request: Request
    goals: dict[str, Goal]  # the goals pursued now
    first: Belief  # at the first look around
    belief: Belief  # now
    given_up: dict[str, str]  # objects out of the task, and why
    ungraspable: frozenset[str]
    extras: tuple[str, ...]  # "put away all": objects beyond the free positions, tried last
    calls: list[PastCall]

    @property
    def failures(self) -> dict[str, str]:
        """The objects given up that fail the task (for "put away all", one that cannot be grasped
        is no item)."""
        items = self.given_up.items()
        return {o: why for o, why in items if not (self.request.all_items and o in self.ungraspable)}

    def end(self, status: Literal["success", "failure"], summary: str) -> Call:
        """The end_task call with this status and summary."""
        return _end(self.task, status, summary)

    def summary(self, n: int) -> str:
        """The report: where the goal objects are, what cannot be grasped, what was not done."""
        where, was = self.belief.where, self.first.where
        moved = [o for o in where if o not in self.request.goals and was.get(o) != where[o]]
        done = [
            f"the {o} is on {where[o][0]} / {where[o][1]}"
            + (f" (it was on {was[o][0]} / {was[o][1]})" if was.get(o, HELD)[1] and was[o] != where[o] else "")
            for o in [*self.request.goals, *moved]
            if where.get(o, HELD)[1]
        ]
        parts = [f"Task: {self.task}", ("Result: " + "; ".join(done) + ".") if done else "Nothing was moved."]
        if self.ungraspable:
            parts.append(f"{UNGRASPABLE_NOTE} {', '.join(sorted(self.ungraspable))}.")
        missed = dict(self.failures)
        unmet = [o for o, g in self.goals.items() if not _satisfied(where.get(o), g) and o not in missed]
        missed |= {o: "not done" for o in unmet}
        if missed:
            parts.append("Could not finish: " + "; ".join(f"{o} ({why})" for o, why in sorted(missed.items())) + ".")
        parts.append(f"It took {n} tool calls.")
        return " ".join(parts)


def _fit(goals: dict[str, Goal], first: Belief, belief: Belief) -> tuple[dict[str, Goal], tuple[str, ...]]:
    """For "put away all the items": the goals that fit the positions of the target, and the rest.
    Objects already there come first, then objects resting on place positions (objects standing
    elsewhere, like a TV, may be fixtures), in the order seen."""
    seen = first.objects()
    rank = sorted(
        goals,
        key=lambda o: (
            not _satisfied(belief.where.get(o), goals[o]),
            not first.where.get(o, HELD)[1],
            seen.index(o) if o in seen else len(seen),
        ),
    )
    location = next(iter(goals.values())).location if goals else ""
    room = [p for p in belief.positions.get(location, []) if belief.occupant.get((location, p)) in (None, *goals)]
    return {o: goals[o] for o in rank[: len(room)]}, tuple(rank[len(room) :])


class Planner:
    """The symbolic planner as a policy: the next tool call for an episode's history."""

    def __call__(self, history: History) -> Call:
        step = self.prepare(history)
        if isinstance(step, Call):
            return step
        action = self.act(step)
        return action if action is not None else self.conclude(step)

    def prepare(self, history: History) -> Call | Episode:
        """Search memory, look around, understand the task and note the plan; then the episode."""
        task, calls = history.task.strip(), history.calls
        names = {c.name for c in calls}
        if "search_memory" not in names:
            return Call("search_memory", {"query": task})
        if "look_around" not in names:
            return Call("look_around")
        first, belief = current_belief(history)
        if first is None or belief is None:  # look_around failed: nothing to plan on
            return _end(task, "failure", "I could not perceive the world.")
        avoid = remembered_ungraspable(history.memories)
        request = understand(task, first, avoid, history.memories)
        if request is None:
            return _end(task, "failure", UNKNOWN_TASK)
        searches = [c for c in calls if c.name == "search_memory"]
        if request.recall and len(searches) < 2:  # ask memory about the object itself, more widely
            return Call("search_memory", {"query": f"Bring the {request.recall}", "k": 20})
        if request.problem:
            known = sorted(avoid & set(first.objects()))
            note = f" {UNGRASPABLE_NOTE} {', '.join(known)}." if known else ""
            return _end(task, "failure", f"Task: {task} I cannot do it: {request.problem}. Nothing was moved.{note}")
        if "add_to_scratchpad" not in names:
            return Call("add_to_scratchpad", {"text": _plan_note(task, request, first, avoid)})
        ungraspable = _grabbed(calls, "error", "not_graspable")
        given_up = {o: "it cannot be grasped" for o in ungraspable}
        given_up |= {o: "no such object" for o in _grabbed(calls, "error", "unknown_object")}
        goals = {o: g for o, g in request.goals.items() if o not in given_up}
        extras: tuple[str, ...] = ()
        if request.all_items:
            goals, extras = _fit(goals, first, belief)
            held_before = _grabbed(calls, "status", "success")
            full = {o: f"no free place position at {request.goals[o].location}" for o in extras if o in held_before}
            given_up |= {o: why for o, why in full.items() if o != belief.holding}
            extras = tuple(o for o in extras if o not in given_up)
        episode = Episode(task, request, goals, first, belief, given_up, frozenset(ungraspable), extras, calls)
        if len(calls) >= MAX_TOOL_CALLS:
            return episode.end("failure", episode.summary(len(calls) + 1) + " I gave up after too many tool calls.")
        if belief.stale:
            return Call("look_around")
        return episode

    def act(self, episode: Episode) -> Call | None:
        """The next action: towards the goals, or, when the task is lost, to leave the hand empty.
        None when there is nothing left to do."""
        belief = episode.belief
        if episode.failures and not episode.request.all_items:
            return _put_down(episode)
        if belief.holding is not None and belief.holding in episode.extras:
            return _put_down(episode)
        untried = _untried(episode)
        if untried and belief.holding is None:
            return _go(belief, belief.where[untried][0], Call("grab", {"object": untried}))
        plan = optimal_plan(belief, episode.goals)
        if plan is None:
            return _put_down(episode)
        if plan:
            return plan[0]
        if episode.extras:
            extra = episode.extras[0]
            return _go(belief, belief.where[extra][0], Call("grab", {"object": extra}))
        return None

    def conclude(self, episode: Episode) -> Call:
        """Nothing left to do: check with a last look, then report truthfully."""
        if episode.calls[-1].name != "look_around":
            return Call("look_around")
        belief = episode.belief
        achieved = belief.holding is None and all(_satisfied(belief.where.get(o), g) for o, g in episode.goals.items())
        status: Literal["success", "failure"] = "success" if achieved and not episode.failures else "failure"
        return episode.end(status, episode.summary(len(episode.calls) + 1))


def _untried(episode: Episode) -> str | None:
    """A goal object not resting on a place position (perhaps a fixture) that the planner has not
    held yet: a task that names it is tried on it first, before anything is moved."""
    if episode.request.all_items:
        return None
    held = _grabbed(episode.calls, "status", "success")
    where = episode.belief.where
    loose = [o for o in episode.goals if o in where and not where[o][1] and o not in held]
    return loose[0] if loose else None


def _put_down(episode: Episode) -> Call | None:
    """Put the held object back where it was (or on the nearest free position); None when the hand
    is empty."""
    belief = episode.belief
    held = belief.holding
    if held is None:
        return None
    origin = episode.first.where.get(held)
    spot = origin if origin and origin[1] and belief.occupant.get((origin[0], origin[1])) is None else _parking(belief)
    if spot is None or spot[1] is None:
        return None
    return _go(belief, spot[0], Call("place", {"location": spot[0], "position": spot[1]}))


def _plan_note(task: str, request: Request, first: Belief, avoid: set[str]) -> str:
    goals = "; ".join(
        f"{o} -> {g.location}" + (f" / {g.position}" if g.position else "") for o, g in request.goals.items()
    )
    plan = optimal_plan(first, request.goals) if not request.all_items else None
    steps = f" Optimal plan: {len(plan)} robot actions." if plan is not None else ""
    known = f" Known not graspable: {', '.join(sorted(avoid))}." if avoid else ""
    return f"Plan ({request.family}) for '{task}': {goals}.{steps}{known}"


class PlannerWrapper(Planner):
    """Alters one step of a policy and delegates the others (as Gymnasium's wrappers do)."""

    def __init__(self, inner: Planner) -> None:
        self.inner = inner

    def prepare(self, history: History) -> Call | Episode:
        return self.inner.prepare(history)

    def act(self, episode: Episode) -> Call | None:
        return self.inner.act(episode)

    def conclude(self, episode: Episode) -> Call:
        return self.inner.conclude(episode)


class Refuser(PlannerWrapper):
    """Never acts: answers in plain text, so the task is never ended."""

    def prepare(self, history: History) -> Call | Episode:
        return Call(None, text=REFUSAL)


class Overconfident(PlannerWrapper):
    """With probability `p` (seeded per task), leaves out the object the policy would have started
    with and reports success without the final look (a task it would fail at once, it reports a
    success too)."""

    def __init__(self, inner: Planner, *, seed: int | None, p: float) -> None:
        super().__init__(inner)
        self.seed, self.p = seed, p

    def sloppy(self, task: str) -> bool:
        """The seeded draw for this task."""
        return random.Random(f"{self.seed}:{task}").random() < self.p

    def prepare(self, history: History) -> Call | Episode:
        step = self.inner.prepare(history)
        if isinstance(step, Call):
            if step.name == "end_task" and self.sloppy(history.task.strip()):
                return replace(step, arguments=step.arguments | {"status": "success"})
            return step
        if not step.goals or not self.sloppy(step.task):
            return step
        hops = step.first.hops_from(step.first.location)
        order = list(step.goals)
        forgotten = min(order, key=lambda o: (hops.get(step.first.where.get(o, HELD)[0], 99), order.index(o)))
        return replace(step, goals={o: g for o, g in step.goals.items() if o != forgotten})

    def conclude(self, episode: Episode) -> Call:
        if not self.sloppy(episode.task):
            return self.inner.conclude(episode)
        return episode.end("success", replace(episode, given_up={}).summary(len(episode.calls) + 1))


def is_variant(name: str) -> TypeGuard[Variant]:
    """Whether `name` is one of the planner's variants."""
    return name in VARIANTS


def policy(variant: Variant = "planner", *, seed: int | None = None, p: float = 0.3) -> Planner:
    """The planner, wrapped for a variant."""
    if variant == "refuser":
        return Refuser(Planner())
    if variant == "overconfident":
        return Overconfident(Planner(), seed=seed, p=p)
    return Planner()


def decide(messages: list[Any], variant: Variant = "planner", *, seed: int | None = None, p: float = 0.3) -> Call:
    """The next move of the planner (or a variant) for the conversation so far."""
    return policy(variant, seed=seed, p=p)(read_history(messages))
