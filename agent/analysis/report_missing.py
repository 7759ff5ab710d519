"""The report's account of the rows a study did not write, and why (from the rows alone).

A study runs every task of every memory iteration of every unit (a model and a trial), with two
exceptions, both by design (docs/study.md): a task that requires another (the paper's T2 requires
T1) runs only after that task truly succeeded earlier in the same iteration; and an errored attempt
ends its trial (the rest would build on a broken memory). A task missing from an iteration is
explained by the first that applies: an errored attempt earlier in the trial, or a task before it
in the iteration that did not succeed.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from robocog.agent.analysis.markdown_table import cell, md_table
from robocog.shared.evaluation import AttemptRow, success

ERRORED = "an errored attempt earlier in its trial ended the trial"
REQUIRED = "a task before it in the iteration did not succeed (a task that requires it runs only after it succeeded)"
UNKNOWN = "not run (the study was stopped, or the rows were removed)"


def missing_rows(rows: Sequence[AttemptRow]) -> list[tuple[str, str, int, str]]:
    """(model, task, rows missing, why), per model, task and reason, in order of appearance."""
    tasks = list(dict.fromkeys(r.task for r in rows))
    iterations = sorted({r.memory_iteration for r in rows})
    counts: Counter[tuple[str, str, str]] = Counter()
    for model in dict.fromkeys(r.model for r in rows):
        mine = [r for r in rows if r.model == model]
        for trial in sorted({r.trial for r in mine}):
            run = [r for r in mine if r.trial == trial]
            errored_at = min(
                ((r.memory_iteration, tasks.index(r.task)) for r in run if r.outcome == "error"), default=None
            )
            for i in iterations:
                here = {r.task: r for r in run if r.memory_iteration == i}
                for j, task in enumerate(tasks):
                    if task in here:
                        continue
                    if errored_at is not None and (i, j) > errored_at:
                        why = ERRORED
                    elif any(t in here and not success(here[t]) for t in tasks[:j]):
                        why = REQUIRED
                    else:
                        why = UNKNOWN
                    counts[(model, task, why)] += 1
    return [(m, t, n, why) for (m, t, why), n in counts.items()]


def missing_section(rows: Sequence[AttemptRow]) -> list[str]:
    """The markdown section (one line when no row is missing)."""
    missing = missing_rows(rows)
    if not missing:
        return ["Every task of every memory iteration of every trial has its row.", ""]
    lines = [[cell(m), cell(t), str(n), why] for m, t, n, why in missing]
    return [
        "## Rows not written",
        "",
        "A study writes one row per model, trial, memory iteration and task, but for the two cases below "
        "(by design; see the study's protocol). Numbers of a task are over the rows it has.",
        "",
        md_table(["model", "task", "rows missing", "why"], lines),
        "",
    ]
