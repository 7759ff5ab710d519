"""A deterministic symbolic planner that plays the part of a model: the suite's oracle.

It is stateless like an LLM: each turn it reads the conversation (the task, and every tool call
with its result), rebuilds what it believes about the world (`robocog.agent.policies.belief`), and decides
the next tool call. So it runs through exactly the same agent loop as any model (see
`robocog.agent.policies.providers`).

It searches its episodic memory, looks around, understands the task as goals (where each object
should end up: objects named by name, by a description or by where they are), and says at once,
honestly, when they cannot be met (no such object, an object it remembers cannot be grasped, more
objects than free place positions). It writes its plan on the scratchpad, then each turn takes the
first step of an optimal plan from what it believes now: the one A* search over the symbolic world
(`robocog.agent.symbolic.rearrangement`: move_to, grab and place cost one each; among the shortest
plans, the one that drives the fewest map hops), which parks an object on a free position when a
goal needs it (a swap, a rearrangement).
An object not resting on a place position may be a fixture (the TV): when the task needs it, the
planner tries to grasp it before it moves anything else; "put away all the items" tries such
objects last, as they may not be items at all. It recovers from failures and from what changes
under it (a slip, a moved object, a blocked corridor: `robocog.agent.policies.recovery`) by looking
again, driving round a block or waiting it out, and giving up honestly on what stays out of reach;
it verifies with a last look, and ends with a truthful report, leaving nothing in the hand.

The planner is one policy (`Planner`): `prepare` reads the episode and does the preliminaries,
`act` takes the next step towards the goals, `conclude` verifies and reports. The variants are
wrappers around it, as instruments for validating the evaluation: `Overconfident` sometimes
(seeded probability) forgets one object and reports success without checking; `Refuser` never
acts. `decide` builds the policy for a variant and asks it for the next move.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from robocog.agent.policies import explore, recovery
from robocog.agent.policies.belief import UNGRASPABLE_NOTE, Belief, Goal, Request
from robocog.agent.policies.history import Call as Call  # re-exported: the planner's step
from robocog.agent.policies.history import (
    History,
    PastCall,
    current_belief,
    remembered_ungraspable,
    understand,
)
from robocog.agent.symbolic import rearrangement
from robocog.agent.symbolic.rearrangement import HELD, satisfied

#: The planner gives up (honestly) after this many tool calls in one episode (a search of a large house
#: under partial observation takes a move and a look per location).
MAX_TOOL_CALLS = 150
#: The robot actions, the steps of a plan.
ROBOT_ACTIONS = ("move_to", "grab", "place", "open", "close")


# --- the optimal plan ------------------------------------------------------------------------------


def optimal_plan(belief: Belief, goals: dict[str, Goal]) -> list[Call] | None:
    """The fewest move_to/grab/place calls that meet every goal and leave the hand empty (among
    those, the plan driving the fewest map hops); None when there is none (or the search gives up).
    See `robocog.agent.symbolic.rearrangement`, the problem, and `robocog.agent.symbolic.search`."""
    plan = rearrangement.optimal_plan(belief, goals)
    return None if plan is None else [Call(name, dict(arguments)) for name, arguments in plan]


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
        return _end(self.task, status, summary)  # the end_task call with this status and summary

    def report(self) -> Call:
        """The truthful end_task: success when the goals hold as believed and nothing failed."""
        where, goals = self.belief.where, self.goals.items()
        done = self.belief.holding is None and all(satisfied(where.get(o), g) for o, g in goals) and not self.failures
        return self.end("success" if done else "failure", self.summary(len(self.calls) + 1))

    def summary(self, n: int) -> str:
        """The report: where the goal objects are, what cannot be grasped, what was not done."""
        where, was = self.belief.where, self.belief.first_seen | self.first.where  # or first seen later
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
        unmet = [o for o, g in self.goals.items() if not satisfied(where.get(o), g) and o not in missed]
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
            not satisfied(belief.where.get(o), goals[o]),
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
        if action is None:
            return self.conclude(step)
        if action.name != "move_to":  # only a drive takes a detour
            return action
        return recovery.detour(action, step.belief, recovery.read_setbacks(step.calls))

    def prepare(self, history: History) -> Call | Episode:
        """Search memory, look around, understand the task and note the plan; then the episode."""
        task, calls = history.task.strip(), history.calls
        names = {c.name for c in calls}
        if "search_memory" not in names and self.prepares(task):
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
        if request.explore or request.look_in:  # names of what the first look did not show
            request = explore.ground(request, belief)
        searches = [c for c in calls if c.name == "search_memory"]
        if request.recall and len(searches) < 2:  # ask memory about the object itself, more widely
            return Call("search_memory", {"query": f"Bring the {request.recall}", "k": 20})
        if request.problem:
            known = sorted(avoid & set(first.objects()))
            note = f" {UNGRASPABLE_NOTE} {', '.join(known)}." if known else ""
            return _end(task, "failure", f"Task: {task} I cannot do it: {request.problem}. Nothing was moved.{note}")
        if "add_to_scratchpad" not in names and self.prepares(task):
            return Call("add_to_scratchpad", {"text": _plan_note(task, request, first, avoid)})
        ungraspable = _grabbed(calls, "error", "not_graspable")
        given_up = {o: "it cannot be grasped" for o in ungraspable}
        given_up |= {o: "no such object" for o in _grabbed(calls, "error", "unknown_object")}
        lost = recovery.lost(request.goals, belief, recovery.read_setbacks(calls))
        given_up |= {o: why for o, why in lost.items() if o not in given_up}
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
        if (belief.stale or recovery.look_again(calls)) and self.looks_again(calls):  # the world changed under it
            return Call("look_around")
        return episode

    def prepares(self, task: str) -> bool:
        """Whether it searches its memory and notes its plan before acting (the planner: always)."""
        return True

    def looks_again(self, calls: list[PastCall]) -> bool:
        """Whether it looks again when its belief may be out of date (the planner: always)."""
        return True

    def act(self, episode: Episode) -> Call | None:
        """The next action: towards the goals, or, when the task is lost, to leave the hand empty.
        None when there is nothing left to do."""
        belief = episode.belief
        if episode.failures and not episode.request.all_items:
            return _put_down(episode)
        if belief.holding is not None and belief.holding in episode.extras:
            return _put_down(episode)
        move = explore.next_move(episode.request, episode.goals, belief)  # containers, the search
        if move is not None and move.tool is None:
            return episode.end("failure", f"{episode.summary(len(episode.calls) + 1)} {move.reason}")
        if move is not None:
            return Call(move.tool, move.arguments)
        untried = _untried(episode)
        if untried and belief.holding is None:
            return _go(belief, belief.where[untried][0], Call("grab", {"object": untried}))
        plan = optimal_plan(belief, episode.goals)
        if plan is None:  # under partial observation, another location may have room to work
            more = explore.room_to_work(belief)
            return _put_down(episode) if more is None else Call(more.tool, more.arguments)
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
        return episode.report()


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
