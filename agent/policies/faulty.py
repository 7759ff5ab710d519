"""`scripted/faulty`: the planner committing each error of the taxonomy at a set rate, an instrument
for measuring the taxonomy (`robocog.agent.analysis.instrument`).

Per attempt, each class of error is drawn independently (seeded by the attempt's model seed, which
the harness derives from the study's seed, the trial, the memory iteration and the task), and the
errors drawn are committed for real, so the server answers them as it would a model's:

- `hallucination`: a move_to to a location no scene has (`FAKE_LOCATION`, answered
  `unknown_location`) or, holding something, a place on a position the location does not have
  (`FAKE_POSITION`, `unknown_position`), the kind drawn per attempt; then the planner carries on.
- `affordance`: a place with an empty hand at a position where the robot stands (`nothing_held`)
  or, holding something, a grab of another object (`already_holding`), the kind drawn too.
- `wrong_order`: the grab or place of the plan's next step sent before the move_to it needs
  (`not_at_location`, or `out_of_reach` with the server's move_to hint).
- `additional_step`: an unneeded move_to the location the robot is already at (a successful robot
  action beyond the optimum).
- `missing_step`: once the other errors drawn are done and a grab or place has succeeded, the task
  is ended as a success with plan steps left undone (a false claim, on a feasible task).
- `false_success`: where the planner would end with an honest failure (an infeasible task: it never
  fails a feasible one), it claims success instead. Unlike `missing_step`, nothing was skipped: the
  claim is the only error, and the taxonomy has no category for it (the verdict scores it: believed
  against true success).
- `ignored_perturbation`: when the world surprises the planner (a result says "Something changed",
  or a robot action fails for a reason its belief cannot account for: the planner would look again),
  it looks no more and ends claiming success with its plan unfinished (a false claim, logged as a
  missing step too); it also ends without the final verifying look (its report then says what it
  believes, without checking). A look the planner takes into a container it has just opened is no
  surprise: the instrument takes it.

None of the acting errors changes the world, and the planner inside reads the episode without them
(`_unfaulted`): it would otherwise take the instrument's own deliberate failure for a surprise of the
world and look again (`robocog.agent.policies.recovery`), which an attempt ignoring perturbations
answers by ending at once, cutting the errors still to come short.

Which errors an attempt may commit is a function of its seed and the rates (`draws`); which it did
commit, the instrument logs itself: every call that commits an error carries, as the text of its
model turn, `LOG` and the classes it commits ("scripted/faulty commits: affordance"). The trace
records the model turns apart from the tool results the taxonomy reads, and `committed` reads the
log back: the truth is what the instrument did, never what the taxonomy found. A drawn error the
attempt gave no chance to commit (a missing step in a task declined at once) is not in it.
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

from robocog.agent.policies import recovery
from robocog.agent.policies.history import Call, History, PastCall, read_history
from robocog.agent.policies.planner import Episode, Planner, optimal_plan
from robocog.agent.policies.variants import PlannerWrapper
from robocog.shared.trace import ModelTurn, TraceEvent

#: Every class of error the instrument commits, in the order they are drawn.
CLASSES = (
    "hallucination",
    "affordance",
    "wrong_order",
    "missing_step",
    "additional_step",
    "false_success",
    "ignored_perturbation",
)
#: The errors committed while acting, in the order they are committed (missing_step ends the task).
_ACTING = ("hallucination", "affordance", "wrong_order", "additional_step", "missing_step")
#: A location in no scene.
FAKE_LOCATION = "Wine Cellar"
#: A place position no location has.
FAKE_POSITION = "attic shelf"
#: The rate of every class when the model's parameters name none.
DEFAULT_RATE = 0.3
_ALREADY_AT = "The robot is already at"
_ORDER_ERRORS = frozenset({"not_at_location", "out_of_reach"})


def rates(params: Mapping[str, Any]) -> dict[str, float]:
    """The rate of each class from a model's parameters: `rate` for all (default 0.3), and
    `rate_<class>` for one (also read from `extra_body`, as providers pass them)."""
    merged = {**(params.get("extra_body") or {}), **params}
    every = float(merged.get("rate", DEFAULT_RATE))
    out = {c: float(merged.get(f"rate_{c}", every)) for c in CLASSES}
    bad = {c: r for c, r in out.items() if not 0.0 <= r <= 1.0}
    if bad:
        raise ValueError(f"rates must lie in [0, 1], not {bad}")
    return out


def draws(seed: int | None, class_rates: Mapping[str, float]) -> frozenset[str]:
    """The classes drawn for an attempt with this model seed: one uniform draw per class, in
    `CLASSES` order, whatever the rates (so changing one rate leaves the others' draws alone)."""
    rng = random.Random(f"faulty:{seed}")
    return frozenset(c for c in CLASSES if rng.random() < class_rates.get(c, 0.0))


#: What the instrument's model turn says when its call commits errors, before their classes.
LOG = "scripted/faulty commits: "


def logged(call: Call, *faults: str) -> Call:
    """`call`, its model turn logging that it commits `faults`."""
    return replace(call, text=LOG + ", ".join(faults))


def committed(events: Iterable[TraceEvent]) -> frozenset[str]:
    """The errors the instrument logged in a trace (its model turns' text; see `LOG`)."""
    out: set[str] = set()
    for e in events:
        if isinstance(e, ModelTurn) and isinstance(text := e.message.get("content"), str) and text.startswith(LOG):
            out.update(f.strip() for f in text.removeprefix(LOG).split(","))
    return frozenset(out)


def _error(c: PastCall) -> str | None:
    return str(c.result.get("error")) if c.result and c.result.get("error") else None


def _shows(fault: str, c: PastCall) -> bool:
    """Whether a call is this policy's `fault` (the planner itself never makes such a call)."""
    if fault == "hallucination":
        return c.arguments.get("location") == FAKE_LOCATION or c.arguments.get("position") == FAKE_POSITION
    if fault == "affordance":
        return (c.name, _error(c)) in (("place", "nothing_held"), ("grab", "already_holding"))
    if fault == "wrong_order":
        return c.name in ("grab", "place") and _error(c) in _ORDER_ERRORS
    if fault == "additional_step":
        return c.name == "move_to" and c.result is not None and str(c.result.get("message", "")).startswith(_ALREADY_AT)
    return False


def _committed(fault: str, calls: list[PastCall]) -> bool:
    """Whether the episode already holds this error."""
    return any(_shows(fault, c) for c in calls)


def _unfaulted(calls: list[PastCall], faults: frozenset[str]) -> list[PastCall]:
    """The calls the planner made: the episode without the errors this policy committed (the first
    call showing each of its faults). None of them changed the world, so the planner reads the rest
    as it would have without them: its own deliberate failure is no surprise of the world to look
    again at, and no setback to give up after."""
    mine = {next((i for i, c in enumerate(calls) if _shows(f, c)), None) for f in faults}
    return [c for i, c in enumerate(calls) if i not in mine]


class Faulty(PlannerWrapper):
    """The planner committing the errors in `faults` (see the module's docstring)."""

    def __init__(self, inner: Planner, *, faults: frozenset[str], seed: int | None = None) -> None:
        super().__init__(inner)
        self.faults = faults
        self.by_hand = random.Random(f"faulty-kind:{seed}").random() < 0.5  # the kind of the two errors

    def prepare(self, history: History) -> Call | Episode:
        own = replace(history, calls=_unfaulted(history.calls, self.faults))
        step = self.inner.prepare(own)
        if isinstance(step, Episode):  # the errors committed stay in the episode (and its count of calls)
            return replace(step, calls=history.calls)
        if step.name == "end_task":
            return self._claim(step)
        if step.name == "look_around" and "ignored_perturbation" in self.faults and recovery.surprised(own.calls):
            summary = f"Task: {history.task.strip()} Done as planned."
            end = Call("end_task", {"status": "success", "description": history.task.strip(), "summary": summary})
            return logged(end, "ignored_perturbation", "missing_step")
        return step

    def act(self, episode: Episode) -> Call | None:
        planned = self.inner.act(episode)
        if planned is None:
            return None
        pending = [f for f in _ACTING if f in self.faults and not _committed(f, episode.calls)]
        for fault in pending:
            call = self._commit(fault, episode, planned, last=len(pending) == 1)
            if call is not None:
                return logged(call, fault)
        return planned

    def conclude(self, episode: Episode) -> Call:
        step = self.inner.conclude(episode)
        if step.name == "look_around" and "ignored_perturbation" in self.faults:  # no verifying look
            claim = self._claim(episode.report())
            faults = [*claim.text.removeprefix(LOG).split(", ")] if claim.text else []
            return logged(claim, "ignored_perturbation", *faults)
        return self._claim(step)

    def _claim(self, step: Call) -> Call:
        """The end_task call, its honest failure turned into a claimed success with `false_success`."""
        failure = step.name == "end_task" and step.arguments.get("status") == "failure"
        if failure and "false_success" in self.faults:
            return logged(replace(step, arguments=step.arguments | {"status": "success"}), "false_success")
        return step

    def _commit(self, fault: str, episode: Episode, planned: Call, *, last: bool) -> Call | None:
        """The call committing `fault` now, or None when it cannot be committed at this step."""
        belief = episode.belief
        here = belief.positions.get(belief.location) or []
        if fault == "hallucination" and not self.by_hand:
            return Call("move_to", {"location": FAKE_LOCATION})
        if fault == "hallucination":  # once something is held where there are positions
            held = belief.holding is not None and here
            return Call("place", {"location": belief.location, "position": FAKE_POSITION}) if held else None
        if fault == "affordance" and self.by_hand:  # once something is held
            others = [o for o in belief.where if o != belief.holding]
            return Call("grab", {"object": others[0]}) if belief.holding is not None and others else None
        if fault == "affordance":
            empty = belief.holding is None and here
            return Call("place", {"location": belief.location, "position": here[0]}) if empty else None
        if fault == "wrong_order":
            if planned.name != "move_to":
                return None
            plan = optimal_plan(belief, episode.goals) or []
            if len(plan) > 1 and plan[0] == planned and plan[1].name in ("grab", "place"):
                return plan[1]
            return None
        if fault == "additional_step":
            return Call("move_to", {"location": belief.location})
        done = any(c.name in ("grab", "place") and not c.is_error for c in episode.calls)
        if fault == "missing_step" and last and done and not episode.failures:
            return episode.end("success", f"Task: {episode.task} Done.")
        return None


def decide(messages: list[Any], seed: int | None, class_rates: Mapping[str, float]) -> Call:
    """`scripted/faulty`'s next move for the conversation so far (the attempt's model seed, the rates)."""
    faults = draws(seed, class_rates)
    return Faulty(Planner(), faults=faults, seed=seed)(read_history(messages))
