"""The report's section on instances with earlier tasks (the memory family): the earlier task scored
as its own row, and the instance's success alone (every attempt; one not run because its earlier
task failed is a failure) and conditional on the earlier task's success (only the instances that ran).

Errored attempts are left out (`robocog.shared.evaluation.ERRORED_POLICY`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.agent.analysis.stats import wilson
from robocog.shared.evaluation import AttemptRow, counted, success


def _rate(rows: Sequence[AttemptRow]) -> dict[str, Any]:
    wins = sum(success(r) for r in rows)
    n = len(rows)
    low, high = wilson(wins, n)
    return {"successes": wins, "n": n, "rate": wins / n if n else None, "ci": [low, high] if n else None}


def memory_scores(rows: Sequence[AttemptRow]) -> list[dict[str, Any]]:
    """Per model and family of the instances that have earlier tasks: the earlier tasks' success, the
    instance's success alone and after an earlier task that succeeded (empty when none has)."""
    kept = [r for r in rows if counted(r)]
    chained = {(r.model, r.instance) for r in kept if r.earlier is not None}
    out = []
    for model, family in dict.fromkeys((r.model, r.family) for r in kept if (r.model, r.instance) in chained):
        mine = [r for r in kept if r.model == model and r.family == family and (model, r.instance) in chained]
        earlier = [r for r in mine if r.earlier is not None]
        own = [r for r in mine if r.earlier is None]
        ran = [r for r in own if r.outcome != "not_run"]
        out.append(
            {
                "model": model,
                "family": family,
                "earlier": _rate(earlier),
                "alone": _rate(own),
                "after_earlier_success": _rate(ran),
                "not_run": len(own) - len(ran),
            }
        )
    return out


def _cell(score: dict[str, Any]) -> str:
    if not score["n"]:
        return "n/a"
    low, high = score["ci"]
    return f"{pct(score['rate'])} ({score['successes']}/{score['n']}; {pct(low)} – {pct(high)})"


def memory_section(scores: Sequence[dict[str, Any]]) -> list[str]:
    """The markdown section (nothing when no instance had an earlier task)."""
    if not scores:
        return []
    lines = [
        [
            cell(s["model"]),
            cell(s["family"]),
            _cell(s["earlier"]),
            _cell(s["alone"]),
            _cell(s["after_earlier_success"]),
            str(s["not_run"]),
        ]
        for s in scores
    ]
    header = ["model", "family", "earlier task", "success alone", "success after the earlier task succeeded", "not run"]
    return [
        "## Instances with an earlier task",
        "",
        "An instance of the memory family runs an earlier task first, in the same world; that task is "
        "scored as its own row (never as the instance, nor against the instance's optimum). *Success alone* "
        "counts every attempt at the instance, one not run because its earlier task failed as a failure (as "
        "the per-family table does); *success after the earlier task succeeded* counts only the instances "
        "that ran. 95% Wilson intervals.",
        "",
        md_table(header, lines),
        "",
    ]
