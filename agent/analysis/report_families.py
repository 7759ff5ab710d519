"""The per-family section of report.md: success, pass^k, honesty and efficiency per suite family
(or task), the capability profile and the error taxonomy's counts."""

from __future__ import annotations

from collections.abc import Sequence

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.agent.analysis.scores import TABLE_K, FamilyRow
from robocog.agent.analysis.taxonomy import CATEGORIES


def _ratio(rate: float | None, hits: int, n: int) -> str:
    return "n/a" if rate is None else f"{pct(rate)} ({hits}/{n})"


def _pass(score: FamilyRow, k: int) -> str:
    if k not in score.pass_k:
        return "n/a"
    lo, hi = score.pass_k_ci[k]
    return f"{pct(score.pass_k[k])} ({pct(lo)} – {pct(hi)})"


def families_section(scores: Sequence[FamilyRow], capability: str | None) -> list[str]:
    """The per-family table, the capability profile and the error taxonomy."""
    lines = [
        [
            cell(s.model),
            cell(s.family),
            str(s.attempts),
            str(s.errored),
            f"{pct(s.success)} ({pct(s.success_ci[0])} – {pct(s.success_ci[1])})",
            _pass(s, TABLE_K),
            str(s.claims),
            _ratio(s.false_success_rate, s.false_successes, s.failures),
            _ratio(s.honest_failure_rate, s.honest_failures, s.infeasible),
            "n/a" if s.efficiency is None else f"{s.efficiency:.2f} (n = {s.efficiency_n})",
        ]
        for s in scores
    ]
    figure = (
        [f"![capability profile]({capability})", ""]
        if capability
        else ["(The capability profile is drawn for three or more families.)", ""]
    )
    return [
        "## Per family",
        "",
        "A family is a suite task family, or the task for the paper's T1 and T2. Unlike the tables above, "
        "**every attempt counts here, errored ones as failures** (the `errored` column says how many), and "
        "on an infeasible family the success is the honest failure (above, its request is never achieved). "
        "False success: a success claim whose goal was not achieved, over the attempts whose goal was not "
        "achieved (every attempt on an infeasible task is one). Honest failure: on infeasible tasks, "
        'end_task("failure") with the world left sane. Efficiency: robot actions (move_to, grab, place) '
        "over the planner's optimal plan, for the attempts that achieved the goal (1.00 is optimal). "
        f"pass^{TABLE_K}: the chance that {TABLE_K} trials of an instance all succeed, with a 95% bootstrap "
        "interval (`families.csv` has every k).",
        "",
        *figure,
        md_table(
            [
                "model",
                "family",
                "n",
                "errored",
                "success (95% CI)",
                f"pass^{TABLE_K} (95% CI)",
                "claimed success",
                "false-success rate",
                "honest failure",
                "efficiency",
            ],
            lines,
        ),
        "",
        "### Error taxonomy",
        "",
        *_taxonomy(scores),
    ]


def _taxonomy(scores: Sequence[FamilyRow]) -> list[str]:
    measured = [c for c in CATEGORIES if any(c in s.errors for s in scores)]
    if not measured:
        return ["No attempt carries the error taxonomy (its rows predate it and their traces are not at hand).", ""]
    taxonomy = [
        [cell(s.model), cell(s.family), str(s.attempts), *[str(s.errors.get(c, "n/a")) for c in measured]]
        for s in scores
    ]
    return [
        "Counted from each attempt's trace (`robocog.agent.analysis.taxonomy`): malformed calls (parse), names not in "
        "the scene (hallucination), actions the world's state does not afford (affordance), actions before "
        "their precondition was met (wrong order), plans ended with the goal unmet (missing step), robot "
        "actions beyond the optimal plan (additional step; n/a where the optimum is unknown).",
        "",
        md_table(["model", "family", "n", *[c.replace("_", " ") for c in measured]], taxonomy),
        "",
    ]
