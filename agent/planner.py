"""A deterministic symbolic planner that plays the part of a model.

It is stateless like an LLM: each turn it reads the conversation (the task, and every tool call
with its result), rebuilds what it believes about the world (`robocog.agent.belief`), and decides
the next tool call. So it runs through exactly the same agent loop as any model (see
`robocog.agent.providers`).

It searches its episodic memory, looks around, writes its plan on the scratchpad, then rearranges
objects greedily (nearest first, over the semantic map from look_around), recovers from failures
(an occupied position: take a free one; something held: put it down first; an object that cannot
be grasped: drop it from the plan and remember it), verifies with a last look, and ends with a
truthful report. Task families: put items away into a location (T1), swap two items (T2), bring an
item to a location. Anything else gets an honest end_task failure.

The planner is one policy (`Planner`): `prepare` reads the episode and does the preliminaries,
`act` takes the next step towards the goals, `conclude` verifies and reports. The variants are
wrappers around it, as instruments for validating the evaluation: `Overconfident` sometimes
(seeded probability) forgets one object and reports success without checking; `Refuser` never
acts. `decide` builds the policy for a variant and asks it for the next move.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field, replace
from typing import Any, Literal, TypeGuard

from robocog.agent.belief import (
    UNGRASPABLE_NOTE,
    Belief,
    Goal,
    History,
    PastCall,
    current_belief,
    read_history,
    remembered_ungraspable,
    understand,
)

Variant = Literal["planner", "overconfident", "refuser"]
VARIANTS: tuple[Variant, ...] = ("planner", "overconfident", "refuser")

#: The planner gives up (honestly) after this many tool calls in one episode.
MAX_TOOL_CALLS = 80


@dataclass(frozen=True)
class Call:
    """The next tool call the planner wants, or a plain text answer when `name` is None."""

    name: str | None
    arguments: dict[str, Any] = field(default_factory=dict)
    text: str = ""


# --- deciding --------------------------------------------------------------------------------------


def _satisfied(belief: Belief, obj: str, goal: Goal) -> bool:
    where = belief.where.get(obj)
    return bool(where and where[0] == goal.location and where[1] and (goal.position in (None, where[1])))


def _target_position(belief: Belief, goal: Goal, reserved: set[tuple[str, str]]) -> str | None:
    if goal.position is not None:
        return goal.position if belief.occupant.get((goal.location, goal.position)) is None else None
    free = [p for p in belief.free_positions(goal.location) if (goal.location, p) not in reserved]
    return free[0] if free else None


def _parking(belief: Belief, reserved: set[tuple[str, str]]) -> tuple[str, str] | None:
    """The nearest free position that no pending goal needs."""
    hops = belief.hops_from(belief.location)
    for loc in sorted(hops, key=lambda n: (hops[n], n)):
        for p in belief.free_positions(loc):
            if (loc, p) not in reserved:
                return loc, p
    return None


def next_action(belief: Belief, goals: dict[str, Goal], skip: set[str]) -> Call | None:
    """The next action towards the goals, or None when every goal holds."""
    pending = {o: g for o, g in goals.items() if o not in skip and not _satisfied(belief, o, g)}
    reserved = {(g.location, g.position) for g in pending.values() if g.position}
    if belief.holding is not None:
        held = belief.holding
        goal = pending.get(held)
        spot: tuple[str, str] | None = None
        if goal is not None:
            pos = _target_position(belief, goal, reserved - {(goal.location, goal.position or "")})
            spot = (goal.location, pos) if pos else None
        spot = spot or _parking(belief, reserved)
        if spot is None:
            return None
        if belief.location != spot[0]:
            return Call("move_to", {"location": spot[0]})
        return Call("place", {"location": spot[0], "position": spot[1]})
    if not pending:
        return None
    hops = belief.hops_from(belief.location)
    unknown = [o for o in pending if o not in belief.where]
    if unknown:
        return Call("look_around")
    ready = [o for o, g in pending.items() if _target_position(belief, g, reserved - {(g.location, g.position or "")})]
    if ready:
        choice = min(ready, key=lambda o: (hops.get(belief.where[o][0], 99), list(goals).index(o)))
    else:
        # Every goal is taken. A goal held by an object with no goal of its own: clear that one away.
        blockers = [
            b
            for g in pending.values()
            if g.position
            and (b := belief.occupant.get((g.location, g.position))) not in (None, *pending)
            and b in belief.where
        ]
        pool = blockers or list(pending)
        choice = min(pool, key=lambda o: (hops.get(belief.where[o][0], 99), o not in goals, o))
    where = belief.where[choice][0]
    if belief.location != where:
        return Call("move_to", {"location": where})
    return Call("grab", {"object": choice})


def _summary(
    task: str,
    belief: Belief,
    goals: dict[str, Goal],
    skip: set[str],
    ungraspable: set[str],
    n: int,
    why: dict[str, str] | None = None,
) -> str:
    done = [
        f"the {o} is on {belief.where[o][0]} / {belief.where[o][1]}"
        for o in goals
        if o in belief.where and belief.where[o][1]
    ]
    parts = [f"Task: {task}", ("Result: " + "; ".join(done) + ".") if done else "Nothing was moved."]
    if ungraspable:
        parts.append(f"{UNGRASPABLE_NOTE} {', '.join(sorted(ungraspable))}.")
    missed = sorted(o for o in skip if o not in ungraspable)
    if missed:
        reasons = why or {}
        parts.append(
            "Could not finish: " + "; ".join(f"{o} ({reasons[o]})" if o in reasons else o for o in missed) + "."
        )
    parts.append(f"It took {n} tool calls.")
    return " ".join(parts)


# --- the policy ------------------------------------------------------------------------------------

REFUSAL = "I believe this task has already been completed, so there is nothing left to do."


@dataclass(frozen=True)
class Episode:
    """What the planner has worked out when it is ready to act on the world."""

    task: str
    family: str
    goals: dict[str, Goal]
    first: Belief  # at the first look around
    belief: Belief  # now
    skip: frozenset[str]  # goals given up (or, for a wrapper, left out)
    ungraspable: frozenset[str]
    why: dict[str, str]  # reasons for the goals given up
    calls: list[PastCall]

    def end(self, status: Literal["success", "failure"], summary: str) -> Call:
        """The end_task call with this status and summary."""
        return Call("end_task", {"status": status, "description": self.task, "summary": summary})


def _grabbed(calls: list[PastCall], key: str, value: str) -> set[str]:
    """The objects of the episode's grab calls whose result has `key` = `value`."""
    return {
        str(c.arguments["object"])
        for c in calls
        if c.name == "grab" and "object" in c.arguments and c.result and c.result.get(key) == value
    }


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
        task = history.task.strip()
        names = [c.name for c in history.calls]
        if "search_memory" not in names:
            return Call("search_memory", {"query": task})
        if "look_around" not in names:
            return Call("look_around")
        first, belief = current_belief(history)
        if first is None or belief is None:  # look_around failed: nothing to plan on
            return Call(
                "end_task", {"status": "failure", "description": task, "summary": "I could not perceive the world."}
            )
        avoid = remembered_ungraspable(history.memories)
        understood = understand(task, first, avoid)
        if understood is None:
            return Call(
                "end_task",
                {
                    "status": "failure",
                    "description": task,
                    "summary": "I do not know how to do this task. I can put items away into a location, swap two "
                    "items, and bring an item to a location.",
                },
            )
        family, goals = understood
        if "add_to_scratchpad" not in names:
            plan = "; ".join(
                f"{o} -> {g.location}" + (f" / {g.position}" if g.position else "") for o, g in goals.items()
            )
            note = f" Known not graspable: {', '.join(sorted(avoid))}." if avoid else ""
            return Call("add_to_scratchpad", {"text": f"Plan ({family}) for '{task}': {plan}.{note}"})
        ungraspable = _grabbed(history.calls, "error", "not_graspable") | (avoid & set(goals))
        unreachable_objects = _grabbed(history.calls, "error", "unknown_object")
        skip = {o for o in ungraspable | unreachable_objects if o}
        # A goal "anywhere at L" with no free position at L cannot be met: give it up, honestly.
        full = {
            o
            for o, g in goals.items()
            if g.position is None and not _satisfied(belief, o, g) and not belief.free_positions(g.location)
        }
        # Putting things away, the planner learns by trying whether an object can be grasped at all;
        # one it has held and cannot place stays where it put it back.
        held_before = _grabbed(history.calls, "status", "success")
        full = {o for o in full if family != "put_away" or o in held_before}
        skip |= {o for o in full if o != belief.holding}
        why = {o: f"no free place position at {goals[o].location}" for o in full}
        why |= {o: "no such object" for o in unreachable_objects if o}
        episode = Episode(
            task, family, goals, first, belief, frozenset(skip), frozenset(ungraspable), why, history.calls
        )
        if len(history.calls) >= MAX_TOOL_CALLS:
            summary = _summary(task, belief, goals, skip | set(goals), set(ungraspable), len(history.calls) + 1, why)
            return episode.end("failure", summary)
        if belief.stale:
            return Call("look_around")
        return episode

    def act(self, episode: Episode) -> Call | None:
        """The next action towards the goals not skipped, or None when they all hold in belief."""
        return next_action(episode.belief, episode.goals, set(episode.skip))

    def conclude(self, episode: Episode) -> Call:
        """Every goal holds in belief: check with a last look, then report truthfully."""
        if episode.calls[-1].name != "look_around":
            return Call("look_around")
        skip, goals = set(episode.skip), episode.goals
        achieved = all(_satisfied(episode.belief, o, g) for o, g in goals.items() if o not in skip)
        # Objects that cannot be grasped are not items to put away; for a swap or a bring they are the task.
        gave_up = skip & goals.keys() if episode.family != "put_away" else set()
        summary = _summary(
            episode.task,
            episode.belief,
            goals,
            skip,
            set(episode.ungraspable),
            len(episode.calls) + 1,
            episode.why,
        )
        return episode.end("success" if achieved and not gave_up else "failure", summary)


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
    with and reports success without the final look."""

    def __init__(self, inner: Planner, *, seed: int | None, p: float) -> None:
        super().__init__(inner)
        self.seed, self.p = seed, p

    def sloppy(self, task: str) -> bool:
        """The seeded draw for this task."""
        return random.Random(f"{self.seed}:{task}").random() < self.p

    def prepare(self, history: History) -> Call | Episode:
        step = self.inner.prepare(history)
        if isinstance(step, Call) or not step.goals or not self.sloppy(step.task):
            return step
        hops = step.first.hops_from(step.first.location)
        order = list(step.goals)
        forgotten = min(order, key=lambda o: (hops.get(step.first.where.get(o, ("",))[0], 99), order.index(o)))
        return replace(step, skip=step.skip | {forgotten})

    def conclude(self, episode: Episode) -> Call:
        if not self.sloppy(episode.task):
            return self.inner.conclude(episode)
        summary = _summary(
            episode.task, episode.belief, episode.goals, set(), set(episode.ungraspable), len(episode.calls) + 1
        )
        return episode.end("success", summary)


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
