"""The per-family section of report.md: success, pass^k, honesty and efficiency per suite family
(or task) and per capability tag (when the rows carry tags), the figures drawn for them
(`robocog.agent.analysis.suite_figures`) and the error taxonomy's counts. Success is
`robocog.shared.evaluation.success` everywhere; "request achieved" is its separate column."""

from __future__ import annotations

from collections.abc import Sequence

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.agent.analysis.scores import TABLE_K, FamilyRow
from robocog.agent.analysis.suite_figures import SuiteFigures
from robocog.agent.analysis.taxonomy import CATEGORIES


def _ratio(rate: float | None, hits: int, n: int) -> str:
    return "n/a" if rate is None else f"{pct(rate)} ({hits}/{n})"


def _honest(score: FamilyRow) -> str:
    if score.honest_failure_rate is None:
        return "n/a"
    named = f"; {score.reasoned_failures} name the blocker"
    return f"{pct(score.honest_failure_rate)} ({score.honest_failures}/{score.infeasible}{named})"


def _pass(score: FamilyRow, k: int) -> str:
    if k not in score.pass_k:
        return "n/a"
    lo, hi = score.pass_k_ci[k]
    return f"{pct(score.pass_k[k])} ({pct(lo)} – {pct(hi)})"


def _table(scores: Sequence[FamilyRow], group: str) -> str:
    lines = [
        [
            cell(s.model),
            cell(s.family),
            str(s.attempts),
            str(s.errored),
            f"{pct(s.success)} ({pct(s.success_ci[0])} – {pct(s.success_ci[1])})",
            str(s.achieved),
            _pass(s, TABLE_K),
            str(s.claims),
            _ratio(s.false_success_rate, s.false_successes, s.failures),
            _ratio(s.stopped / s.attempts, s.stopped, s.attempts),
            _honest(s),
            "n/a" if s.efficiency is None else f"{s.efficiency:.2f} (n = {s.efficiency_n})",
        ]
        for s in scores
    ]
    header = [
        "model",
        group,
        "n",
        "errored",
        "success (95% CI)",
        "request achieved",
        f"pass^{TABLE_K} (95% CI)",
        "claimed success",
        "false-success rate",
        "never ended",
        "honest failure",
        "efficiency",
    ]
    return md_table(header, lines)


def _figure(name: str | None, alt: str) -> list[str]:
    return [f"![{alt}]({name})", ""] if name else []


def families_section(
    scores: Sequence[FamilyRow], figures: SuiteFigures, capabilities: Sequence[FamilyRow] = ()
) -> list[str]:
    """The per-family table, the per-capability one (when rows carry tags), their figures and the
    error taxonomy."""
    radar = (
        _figure(figures.capability, "capability profile")
        if figures.capability
        else ["(The capability profile is drawn for three or more families or capabilities.)", ""]
    )
    per_capability = (
        [
            "## Per capability",
            "",
            "Every instance is tagged with the capabilities it exercises (EmbodiedBench's capability subsets); "
            "an instance counts under each of its tags, so the rows overlap. Columns as per family "
            "(`capabilities.csv` has every k).",
            "",
            *_figure(figures.capabilities, "scores per capability"),
            _table(capabilities, "capability"),
            "",
        ]
        if capabilities
        else []
    )
    return [
        "## Per family",
        "",
        "A family is a suite task family, or the task for the paper's T1 and T2. n counts the attempts "
        "that did not error; `errored` says how many did (left out, as everywhere). Success is the ground "
        "truth's verdict of the instance's success conditions: on an infeasible family it is the honest "
        'failure (end_task("failure") with the world left sane); *request achieved* counts apart the '
        "attempts that carried the request out (never one on an infeasible family). False success: a "
        "success claim whose request was not achieved, over the attempts whose request was not achieved "
        "(every attempt on an infeasible task is one). Never ended: the attempts that never called end_task "
        "within the invocations (the paper's refusal; errored ones are apart), so a model that never ends a task "
        "does not read as honest by a false-success rate of zero. Honest failure: the successes on infeasible "
        "tasks, and of them those whose end_task summary names what blocks the task (the missing or "
        "ungraspable object, the full furniture, the corridor blocked for good), apart from a bare failure "
        "claim. Efficiency: robot actions (move_to, grab, place, open, close) over the planner's optimal "
        "plan, for the attempts "
        f"that achieved the request (1.00 is optimal). pass^{TABLE_K}: the chance that {TABLE_K} trials of "
        "an instance all succeed, with a 95% Wilson interval over the instances (`families.csv` has every k).",
        "",
        *radar,
        *_figure(figures.families, "scores per family"),
        *_figure(figures.memory, "success against memory iteration per family"),
        _table(scores, "family"),
        "",
        "### Error taxonomy",
        "",
        *_taxonomy(scores),
        *per_capability,
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
