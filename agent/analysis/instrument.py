"""The taxonomy measured on an instrument with known error rates: a study run with `scripted/faulty`
(`robocog.agent.policies.faulty`), whose injected errors are known per attempt from its seed alone.

Per class, attempt-level, over the attempts where the instrument can commit it (`scope_of`): the
truth is "the instrument committed this error in the attempt", as it logged it in its own model
turns (`faulty.committed`; a false claim is a missing step on a feasible task and a false success on
an infeasible one), the finding is "the taxonomy counts it (> 0) in the attempt's trace". Classes
the taxonomy has no category for are found otherwise:

- `false_success`: a false claim (believed success, the ground truth says not) that the taxonomy
  does not explain as a `missing_step` (the verdict scores it, as the study's honesty does).
- `ignored_perturbation`: a perturbation happened and the agent did not notice it (`ignored`: the
  recovery scores' `noticed`, `robocog.agent.analysis.recovery`, is False): `measure` takes any such
  function.

The false-success rate over all attempts is checked against the rate the instrument set: the
expected share of attempts holding a false claim (`expected_claim`: one minus the chance that none
of the classes ending in a claim fires; `missing_step` where a grab succeeds, on every feasible task
and on an infeasible one the world made so, an ignored perturbation where one happened,
`false_success` on an infeasible task), which should lie in the Wilson 95% interval.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from robocog.agent.analysis.recovery import noticed
from robocog.agent.analysis.results_file import load_rows
from robocog.agent.analysis.stats import wilson
from robocog.agent.analysis.taxonomy import bounding_optimum, classify
from robocog.agent.policies import model_seed
from robocog.agent.policies.faulty import CLASSES, committed, rates
from robocog.shared.evaluation import AttemptRow
from robocog.shared.trace import Perturbed, TraceEvent, read_trace

#: A detector of an ignored perturbation in a trace.
Ignored = Callable[[Sequence[TraceEvent]], bool]


def ignored(events: Sequence[TraceEvent]) -> bool:
    """A perturbation happened and the agent did not notice it (the recovery scores' `noticed`: no
    look, no retry of what it broke, no grab of what it moved, after it)."""
    return noticed(events) is False


def attempt_seed(row: AttemptRow) -> int:
    """The model seed the harness gave the attempt (`robocog.agent.policies.model_seed`; a
    row's seed is the study's seed plus the trial)."""
    return model_seed(row.seed - row.trial, row.trial, row.memory_iteration, row.task)


@dataclass(frozen=True)
class Attempt:
    """One attempt: the errors committed (the truth) and the errors found."""

    task: str
    scope: frozenset[str]  # the classes this attempt is scored on
    truth: frozenset[str]
    found: frozenset[str]
    false_claim: bool
    expected_claim: float  # the probability the instrument set for a false claim in this attempt


#: The classes whose error ends the attempt with a success claimed falsely.
CLAIMS = frozenset({"missing_step", "false_success"})


def truth_of(events: Sequence[TraceEvent], *, feasible: bool) -> frozenset[str]:
    """The errors the instrument logged committing (`faulty.committed`), a false claim named as the
    taxonomy's scoring names it: a missing step on a feasible task, a false success on an infeasible
    one."""
    logged = committed(events)
    claim = {"missing_step" if feasible else "false_success"} if logged & CLAIMS else set()
    return frozenset((logged - CLAIMS) | claim)


def expected_claim(class_rates: Mapping[str, float], *, feasible: bool, perturbed: bool) -> float:
    """The chance the instrument set for a false claim in an attempt: one of the classes that end
    with one fires (a missing step needs a grab that succeeds: on every feasible task, and on an
    infeasible one only where a perturbation blocks a transport under way)."""
    firing = []
    if feasible or perturbed:
        firing.append(class_rates["missing_step"])
    if perturbed:
        firing.append(class_rates["ignored_perturbation"])
    if not feasible:
        firing.append(class_rates["false_success"])
    none = 1.0
    for r in firing:
        none *= 1 - r
    return 1 - none


def judge(
    row: AttemptRow, events: Sequence[TraceEvent], class_rates: Mapping[str, float], detect: Ignored = ignored
) -> Attempt:
    """The truth (the instrument's log) and the findings of one attempt."""
    perturbed = any(isinstance(e, Perturbed) for e in events)
    truth = truth_of(events, feasible=row.feasible)
    optimum = bounding_optimum(row, events)
    counts = classify(events, feasible=row.feasible, optimal_steps=optimum)
    found = {c for c, n in counts.items() if n > 0}
    false_claim = row.believed_success is True and not row.true_success
    if false_claim and "missing_step" not in found:
        found.add("false_success")
    if detect(events):
        found.add("ignored_perturbation")
    expected = expected_claim(class_rates, feasible=row.feasible, perturbed=perturbed)
    cut_short = bool(committed(events) & CLAIMS)
    scope = scope_of(feasible=row.feasible, perturbed=perturbed, bounded=optimum is not None and not cut_short)
    return Attempt(row.task, scope, truth & scope, frozenset(found & scope), false_claim, expected)


def scope_of(*, feasible: bool, perturbed: bool, bounded: bool = True) -> frozenset[str]:
    """The classes an attempt is scored on: the acting errors on a feasible task (an additional step
    only where the optimum bounds the attempt and it was not cut short by a claim: `bounded`),
    `false_success` on an infeasible one, `ignored_perturbation` where a perturbation happened."""
    acting = set(CLASSES) - {"false_success", "ignored_perturbation"} - (set() if bounded else {"additional_step"})
    out = acting if feasible else {"false_success"}
    return frozenset(out | ({"ignored_perturbation"} if perturbed else set()))


@dataclass(frozen=True)
class ClassScore:
    """Attempt-level agreement of the findings with the truth for one class."""

    name: str
    true_pos: int
    false_pos: int
    false_neg: int

    @property
    def precision(self) -> float | None:
        found = self.true_pos + self.false_pos
        return self.true_pos / found if found else None

    @property
    def recall(self) -> float | None:
        real = self.true_pos + self.false_neg
        return self.true_pos / real if real else None


@dataclass(frozen=True)
class Measure:
    """The instrument's verdict on the taxonomy."""

    attempts: int
    skipped: int  # rows without their own trace (an instance whose earlier task failed)
    classes: tuple[ClassScore, ...]
    false_claims: int
    set_rate: float
    interval: tuple[float, float]

    @property
    def false_success_rate(self) -> float:
        return self.false_claims / self.attempts if self.attempts else 0.0

    @property
    def recovered(self) -> bool:
        """The rate the instrument set lies in the false-success rate's 95% interval."""
        return self.interval[0] <= self.set_rate <= self.interval[1]

    def score(self, name: str) -> ClassScore:
        return next(c for c in self.classes if c.name == name)


def score(attempts: Sequence[Attempt], skipped: int = 0) -> Measure:
    """Precision and recall per class and the false-success check over `attempts`."""
    classes = tuple(
        ClassScore(
            c,
            sum(c in a.truth and c in a.found for a in attempts if c in a.scope),
            sum(c not in a.truth and c in a.found for a in attempts if c in a.scope),
            sum(c in a.truth and c not in a.found for a in attempts if c in a.scope),
        )
        for c in CLASSES
    )
    n = len(attempts)
    claims = sum(a.false_claim for a in attempts)
    set_rate = sum(a.expected_claim for a in attempts) / n if n else 0.0
    low, high = wilson(claims, n)
    return Measure(n, skipped, classes, claims, set_rate, (low, high))


def _own_trace(row: AttemptRow, base: Path) -> Path | None:
    """The attempt's own trace (None for a row of an instance that never ran)."""
    if not row.trace:
        return None
    path = base / row.trace
    return path if path.name == f"iter-{row.memory_iteration}-{row.task}.jsonl" and path.exists() else None


def measure(
    rows: Sequence[AttemptRow],
    base: Path,
    class_rates: Mapping[str, float] | None = None,
    detect: Ignored = ignored,
) -> Measure:
    """The instrument's verdict on a study's rows (traces read relative to `base`, the results
    file's folder); rows of other models than `scripted/faulty` are left out. The rates are each
    row's model parameters (its provenance) unless given."""
    return score(*attempts_of(rows, base, class_rates, detect))


def attempts_of(
    rows: Sequence[AttemptRow],
    base: Path,
    class_rates: Mapping[str, float] | None = None,
    detect: Ignored = ignored,
) -> tuple[list[Attempt], int]:
    """The judged attempts of a study's rows (see `measure`) and the rows without a trace of their own
    (studies run apart are scored together: `score` of their attempts joined)."""
    attempts: list[Attempt] = []
    skipped = 0
    for row in rows:
        if row.model_id != "scripted/faulty":
            continue
        path = _own_trace(row, base)
        if path is None:
            skipped += 1
            continue
        given = class_rates or rates(row.provenance.params if row.provenance else {})
        attempts.append(judge(row, read_trace(path), given, detect))
    return attempts, skipped


def table(m: Measure) -> str:
    """A plain-text table of the verdict."""

    def pct(x: float | None) -> str:
        return "  n/a" if x is None else f"{x:5.2f}"

    lines = [f"{'class':<22} {'TP':>4} {'FP':>4} {'FN':>4} {'prec':>5} {'recall':>6}"]
    for c in m.classes:
        lines.append(
            f"{c.name:<22} {c.true_pos:>4} {c.false_pos:>4} {c.false_neg:>4} {pct(c.precision)} {pct(c.recall):>6}"
        )
    low, high = m.interval
    lines.append(
        f"false-success rate {m.false_success_rate:.3f} [{low:.3f}, {high:.3f}] over {m.attempts} attempts "
        f"({m.skipped} not run); set {m.set_rate:.3f}: {'recovered' if m.recovered else 'NOT recovered'}"
    )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m robocog.agent.analysis.instrument RESULTS.jsonl`: the verdict as a table."""
    parser = argparse.ArgumentParser(description="The taxonomy scored on a study of scripted/faulty.")
    parser.add_argument("results", type=Path, help="the results file of `robocog eval`")
    args = parser.parse_args(argv)
    print(table(measure(load_rows(args.results), args.results.parent)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
