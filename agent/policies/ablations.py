"""The oracle with one capability taken away: one ablation per capability tag of the suite, to prove
each tag measures what it says (`scripted/without-<tag>`).

Each is the planner (`robocog.agent.policies.planner`) with one ability removed and nothing else
changed, so it should fail most instances tagged with that capability and pass almost all others:

- `memory`: ignores its episodic memory (it searches, and reads nothing of what it finds);
- `partial_observation`: never explores beyond what it was told: when a goal object is not in sight
  (and the task does not say which container holds it), it ends with failure instead of searching;
- `recovery`: ignores a failed or changed world: at the first surprise (news of a change, a robot
  action that failed) it ends claiming success;
- `containers`: never opens furniture: where its plan would open a drawer, cabinet or fridge, it ends
  with failure;
- `honesty`: always claims success;
- `planning`: no plan: nearest goal object first, each carried straight to its goal (a free position
  of the goal location when the goal names none), never parking one to make room; it ends with
  failure when the position it needs is taken;
- `referring`: reads names only: a goal object the task does not name by name (a description, a
  relation) it cannot resolve, and it says so;
- `long_horizon`: plans no further than `SHORT_HORIZON` robot actions: it gives up after that many.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Literal

from robocog.agent.policies import explore, recovery
from robocog.agent.policies.history import Call, History, read_history
from robocog.agent.policies.planner import ROBOT_ACTIONS, Episode, Planner
from robocog.agent.policies.variants import PlannerWrapper
from robocog.agent.symbolic.rearrangement import HELD, satisfied
from robocog.shared.names import name_key

#: The capability tags, each with its ablation (`scripted/without-<tag>`).
TAGS = (
    "planning",
    "recovery",
    "memory",
    "honesty",
    "referring",
    "long_horizon",
    "partial_observation",
    "containers",
)
#: The most robot actions the ablation without long horizons takes (a long_horizon instance's optimal
#: plan has 30 or more).
SHORT_HORIZON = 29


def _summary(episode: Episode, why: str) -> str:
    return f"{episode.summary(len(episode.calls) + 1)} {why}"


class WithoutMemory(PlannerWrapper):
    """Searches its memory, and reads nothing of what it finds."""

    def prepare(self, history: History) -> Call | Episode:
        step = self.inner.prepare(replace(history, memories=[]))
        return replace(step, calls=history.calls) if isinstance(step, Episode) else step


class WithoutExploration(PlannerWrapper):
    """Acts on what it was told and what it sees: a goal object out of sight, not said to be in a
    container, ends the task with failure."""

    def act(self, episode: Episode) -> Call | None:
        belief = episode.belief
        missing = _missing(episode)
        if missing and belief.location in belief.seen:
            named = ", ".join(f"the {o}" for o in missing)
            return episode.end("failure", _summary(episode, f"I do not see {named}, and I do not search."))
        return self.inner.act(episode)


class WithoutRecovery(PlannerWrapper):
    """At the first surprise of the world, looks no more and claims success."""

    def prepare(self, history: History) -> Call | Episode:
        step = self.inner.prepare(history)
        if isinstance(step, Call) and step.name == "look_around" and recovery.surprised(history.calls):
            task = history.task.strip()
            return Call("end_task", {"status": "success", "description": task, "summary": f"Task: {task} Done."})
        return step


class WithoutContainers(PlannerWrapper):
    """Never opens furniture: a search for a missing object goes on in the open only, and where its plan
    would open a container, it ends with failure."""

    def act(self, episode: Episode) -> Call | None:
        call = self.inner.act(episode)
        if call is None or call.name != "open":
            return call
        if _missing(episode):  # a search that would look inside: it searches what stands in the open
            blind = episode.belief.copy()
            blind.closed = set()
            other = self.inner.act(replace(episode, belief=blind))
            if other is not None and other.name != "open":
                return other
        why = f"The {call.arguments.get('furniture')} is closed, and I do not open furniture."
        return episode.end("failure", _summary(episode, why))


def _missing(episode: Episode) -> list[str]:
    """The goal objects out of sight, and not said to be in a container."""
    belief = episode.belief
    return [o for o in episode.goals if o not in belief.where and o != belief.holding and o not in belief.expected]


class WithoutHonesty(PlannerWrapper):
    """Always claims success."""

    def prepare(self, history: History) -> Call | Episode:
        return _claimed(self.inner.prepare(history))

    def act(self, episode: Episode) -> Call | None:
        call = self.inner.act(episode)
        return None if call is None else _claimed(call)

    def conclude(self, episode: Episode) -> Call:
        return _claimed(self.inner.conclude(episode))


def _claimed(step: Any) -> Any:
    if isinstance(step, Call) and step.name == "end_task":
        return replace(step, arguments=step.arguments | {"status": "success"})
    return step


class WithoutPlanning(PlannerWrapper):
    """No plan: the nearest goal object not yet where it should be, carried straight to its goal."""

    def act(self, episode: Episode) -> Call | None:
        belief = episode.belief
        if episode.failures or explore.next_move(episode.request, episode.goals, belief) is not None:
            return self.inner.act(episode)  # giving up, containers and the search: as the planner
        held = belief.holding
        if held is not None and held in episode.goals:
            goal = episode.goals[held]
            free = belief.free_positions(goal.location)
            position = goal.position or (free[0] if free else None)
            if position is None or belief.occupant.get((goal.location, position)) not in (None, held):
                why = f"The place for the {held} is taken, and I carry each item straight to its place."
                return episode.end("failure", _summary(episode, why))
            if belief.location != goal.location:
                return Call("move_to", {"location": goal.location})
            return Call("place", {"location": goal.location, "position": position})
        if held is not None:
            return self.inner.act(episode)
        hops = belief.hops_from(belief.location)
        todo = [o for o, g in episode.goals.items() if o in belief.where and not satisfied(belief.where.get(o), g)]
        if not todo:
            return None
        nearest = min(todo, key=lambda o: (hops.get(belief.where.get(o, HELD)[0], 99), o))
        where = belief.where[nearest][0]
        return Call("grab", {"object": nearest}) if belief.location == where else Call("move_to", {"location": where})


class WithoutReferring(PlannerWrapper):
    """Reads names only: a goal object the task does not name, it cannot resolve."""

    def prepare(self, history: History) -> Call | Episode:
        step = self.inner.prepare(history)
        if not isinstance(step, Episode) or step.request.all_items:
            return step
        said = f" {name_key(step.task, articles='keep')} "
        unnamed = [o for o in step.request.goals if f" {name_key(o, articles='keep')} " not in said]
        if unnamed:
            why = "I do not know which object the task means: it names none I know by name."
            return step.end("failure", f"Task: {step.task} {why} Nothing was moved.")
        return step


class WithoutLongHorizon(PlannerWrapper):
    """Gives up after `SHORT_HORIZON` robot actions."""

    def act(self, episode: Episode) -> Call | None:
        done = sum(1 for c in episode.calls if c.name in ROBOT_ACTIONS)
        call = self.inner.act(episode)
        if call is not None and call.name in ROBOT_ACTIONS and done >= SHORT_HORIZON:
            why = f"I stop after {SHORT_HORIZON} robot actions: I cannot follow a longer plan."
            return episode.end("failure", _summary(episode, why))
        return call


Tag = Literal[
    "planning", "recovery", "memory", "honesty", "referring", "long_horizon", "partial_observation", "containers"
]
_WRAPPERS: dict[str, type[PlannerWrapper]] = {
    "planning": WithoutPlanning,
    "recovery": WithoutRecovery,
    "memory": WithoutMemory,
    "honesty": WithoutHonesty,
    "referring": WithoutReferring,
    "long_horizon": WithoutLongHorizon,
    "partial_observation": WithoutExploration,
    "containers": WithoutContainers,
}


def model(tag: str) -> str:
    """The model string of the ablation without `tag`."""
    return f"scripted/without-{tag}"


def ablation(tag: str) -> Planner:
    """The planner without the capability `tag` (a ValueError for a tag with no ablation)."""
    if tag not in _WRAPPERS:
        raise ValueError(f"no ablation for {tag!r}; the tags are {', '.join(TAGS)}")
    return _WRAPPERS[tag](Planner())


def decide(messages: list[Any], tag: str) -> Call:
    """The next move of the ablation without `tag`, for the conversation so far."""
    return ablation(tag)(read_history(messages))
