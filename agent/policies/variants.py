"""The planner's variants, by name (`scripted/NAME`): the planner; `refuser`, which never acts;
`overconfident`, which leaves an object out and claims success; `verbose` and `lean`, the planner in
other orders of calls (`robocog.agent.policies.orders`)."""

from __future__ import annotations

import random
from dataclasses import replace
from typing import Any, Literal, TypeGuard

from robocog.agent.policies import orders
from robocog.agent.policies.history import Call, History, read_history
from robocog.agent.policies.planner import REFUSAL, Episode, Planner
from robocog.agent.symbolic.rearrangement import HELD

Variant = Literal["planner", "overconfident", "refuser", "verbose", "lean"]
VARIANTS: tuple[Variant, ...] = ("planner", "overconfident", "refuser", "verbose", "lean")


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
    if variant in ("verbose", "lean"):
        return orders.Verbose() if variant == "verbose" else orders.Lean()
    return Planner()


def decide(messages: list[Any], variant: Variant = "planner", *, seed: int | None = None, p: float = 0.3) -> Call:
    """The next move of the planner (or a variant) for the conversation so far."""
    return policy(variant, seed=seed, p=p)(read_history(messages))
