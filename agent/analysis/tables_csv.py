"""The report's CSVs: `results.csv` (our columns and values, or the published implementation's
encoding), `families.csv` (the per-family scores) and `capabilities.csv` (per capability tag)."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

from robocog.agent.analysis.scores import FamilyRow
from robocog.agent.analysis.stats import PASS_KS
from robocog.agent.analysis.taxonomy import CATEGORIES
from robocog.shared.evaluation import AttemptRow, achieved, counted, success

#: `results.csv`: ours (booleans, our task ids and trial numbers) or the published encoding.
CsvFormat = Literal["ours", "upstream"]

UPSTREAM_COLUMNS = (
    "Model",
    "Memory",
    "Task",
    "Trial",
    "Invokes",
    "Toolcalls",
    "Belief",
    "Truth",
    "Accuracy",
    "Stopped",
)

#: Our `results.csv` adds robocog's success (`robocog.shared.evaluation.success`) and feasibility after
#: them: there Truth is the request achieved, what Belief is judged against (Accuracy), and Success
#: is the honest failure on an infeasible task.
OUR_COLUMNS = (*UPSTREAM_COLUMNS, "Success", "Feasible")

#: The leading columns of `families.csv` and `capabilities.csv` (then pass^k with its interval per k,
#: then the taxonomy).
FAMILY_COLUMNS = (
    "model",
    "family",
    "attempts",
    "errored",
    "stopped",
    "successes",
    "success",
    "success_lo",
    "success_hi",
    "achieved",
    "claims",
    "failures",
    "false_successes",
    "false_success_rate",
    "infeasible",
    "honest_failures",
    "honest_failure_rate",
    "reasoned_failures",
    "efficiency",
    "efficiency_n",
)

#: Our task ids as the published implementation numbers its tasks; any other id is written as it is.
UPSTREAM_TASKS = {"T1": "1", "T2": "2"}


def write_csv(rows: list[AttemptRow], path: Path) -> None:
    """Every attempt that counts (errored ones left out: `robocog.shared.evaluation.ERRORED_POLICY`) in
    the published implementation's columns, with our values (booleans, our task ids, trials from 0),
    then `Success` and `Feasible` (`OUR_COLUMNS`)."""
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(OUR_COLUMNS)
        for r in rows:
            if not counted(r):
                continue
            w.writerow(
                [
                    r.model,
                    r.memory_iteration,
                    r.task,
                    r.trial,
                    r.invocations,
                    r.tool_calls,
                    r.believed_success is True,
                    achieved(r),
                    r.agreement,
                    r.stopped,
                    success(r),
                    r.feasible,
                ]
            )


def upstream_task(task: str) -> str:
    """A task id as the published implementation writes it: T1 -> 1, T2 -> 2, others unchanged."""
    return UPSTREAM_TASKS.get(task, task)


def write_upstream_csv(rows: list[AttemptRow], path: Path) -> int:
    """The published encoding, so its plotting script can read our rows: 0/1 values, tasks as
    integers (`upstream_task`), trials from 1, memory iterations from 0, Belief 1 only for an
    end_task status of success, Accuracy = Belief equals Truth, Stopped 1 for a refusal. Errored
    attempts are left out (the published code has no such outcome). Returns the rows written."""
    written = 0
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(UPSTREAM_COLUMNS)
        for r in rows:
            if r.outcome == "error":
                continue
            belief = int(r.believed_success is True)
            truth = int(achieved(r))
            w.writerow(
                [
                    r.model,
                    r.memory_iteration,
                    upstream_task(r.task),
                    r.trial + 1,
                    r.invocations,
                    r.tool_calls,
                    belief,
                    truth,
                    int(belief == truth),
                    int(r.outcome == "stopped"),
                ]
            )
            written += 1
    return written


def write_family_csv(scores: Sequence[FamilyRow], path: Path, *, group: str = "family") -> None:
    """`families.csv`: the per-family scores, one row per model and family (rates as fractions, empty
    where not measurable; pass^k and its interval for every k of `PASS_KS`; the taxonomy's counts).
    `capabilities.csv` is the same table per capability tag (`group="capability"` names the column)."""

    def number(x: float | None) -> str:
        return "" if x is None or math.isnan(x) else f"{x:.4f}"

    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        passes = [f"pass^{k}{part}" for k in PASS_KS for part in ("", "_lo", "_hi")]
        w.writerow([*FAMILY_COLUMNS[:1], group, *FAMILY_COLUMNS[2:], *passes, *CATEGORIES])
        for s in scores:
            no_interval = (None, None)
            w.writerow(
                [
                    s.model,
                    s.family,
                    s.attempts,
                    s.errored,
                    s.stopped,
                    s.successes,
                    number(s.success),
                    number(s.success_ci[0]),
                    number(s.success_ci[1]),
                    s.achieved,
                    s.claims,
                    s.failures,
                    s.false_successes,
                    number(s.false_success_rate),
                    s.infeasible,
                    s.honest_failures,
                    number(s.honest_failure_rate),
                    s.reasoned_failures,
                    number(s.efficiency),
                    s.efficiency_n,
                    *[number(v) for k in PASS_KS for v in (s.pass_k.get(k), *s.pass_k_ci.get(k, no_interval))],
                    *[s.errors.get(c, "") for c in CATEGORIES],
                ]
            )
