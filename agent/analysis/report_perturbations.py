"""The report's section on perturbations: per model, how the attempts in which something went wrong
in the world (`AttemptRow.perturbations`, from each trace) fared against those in which nothing did.

Errored attempts are left out, as everywhere (`robocog.shared.evaluation.ERRORED_POLICY`). The first
table reads the perturbed attempts by their outcome (true success, and the false-success rate of the
one definition, `robocog.agent.analysis.scores.false_success_rate`: false successes over the perturbed
attempts whose request was not achieved); the
subsection "Recovery" by the recovery scores each row takes from its trace (noticed, recovered, ended
honestly: `robocog.agent.analysis.recovery`), per model and kind of the first perturbation.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.agent.analysis.scores import false_success_rate
from robocog.shared.evaluation import AttemptRow, counted


def _share(rows: Sequence[AttemptRow]) -> tuple[str, float | None]:
    wins = sum(bool(r.true_success) for r in rows)
    return (f"{wins}/{len(rows)}", wins / len(rows) if rows else None)


def perturbation_scores(rows: Sequence[AttemptRow]) -> list[dict[str, Any]]:
    """Per model (in order of appearance): attempts, perturbed attempts and their kinds, true success
    with and without a perturbation, and the false-success rate among the perturbed attempts (false
    successes over those whose request was not achieved)."""
    kept = [r for r in rows if counted(r)]
    if not any(r.perturbations for r in kept):
        return []
    out = []
    for model in dict.fromkeys(r.model for r in kept):
        mine = [r for r in kept if r.model == model]
        hit = [r for r in mine if r.perturbations]
        calm = [r for r in mine if not r.perturbations]
        false, failures = false_success_rate(hit)
        out.append(
            {
                "model": model,
                "attempts": len(mine),
                "perturbed": len(hit),
                "kinds": dict(Counter(kind for r in hit for kind in r.perturbations)),
                "success_perturbed": _share(hit)[1],
                "success_unperturbed": _share(calm)[1],
                "false_success_perturbed": false / failures if failures else None,
                "counts": {"perturbed": _share(hit)[0], "unperturbed": _share(calm)[0], "false": f"{false}/{failures}"},
            }
        )
    return out


def perturbations_section(scores: Sequence[dict[str, Any]]) -> list[str]:
    """The markdown section (nothing when no attempt met a perturbation)."""
    if not scores:
        return []
    lines = [
        [
            cell(s["model"]),
            f"{s['perturbed']} of {s['attempts']}",
            cell(", ".join(f"{k} ×{n}" for k, n in sorted(s["kinds"].items()))),
            f"{pct(s['success_perturbed'])} ({s['counts']['perturbed']})",
            f"{pct(s['success_unperturbed'])} ({s['counts']['unperturbed']})",
            f"{pct(s['false_success_perturbed'])} ({s['counts']['false']})",
        ]
        for s in scores
    ]
    header = ["model", "perturbed", "what went wrong", "success, perturbed", "success, not", "false success, perturbed"]
    return [
        "## Perturbations",
        "",
        "Attempts in which the world changed under the agent (a slip, a moved object, a closed container, a "
        "blocked corridor; see the traces' `perturbation` events) against those in which it did not. False "
        "success as everywhere: success claims whose request was not achieved, over the perturbed attempts "
        "whose request was not achieved.",
        "",
        md_table(header, lines),
        "",
    ]


def _rate(rows: Sequence[AttemptRow], field: str) -> tuple[float | None, str]:
    known = [getattr(r, field) for r in rows if getattr(r, field) is not None]
    wins = sum(bool(v) for v in known)
    return (wins / len(known) if known else None, f"{wins}/{len(known)}")


def recovery_rates(rows: Sequence[AttemptRow]) -> list[dict[str, Any]]:
    """Per model and kind of the first perturbation (in order of appearance): the perturbed attempts
    scored (`AttemptRow.noticed`, `recovered`, `honest`: agent/analysis/recovery.py) and the rates at
    which the agent noticed, recovered and ended honestly."""
    scored = [r for r in rows if counted(r) and r.perturbations and r.noticed is not None]
    out = []
    for model, kind in dict.fromkeys((r.model, r.perturbations[0]) for r in scored):
        mine = [r for r in scored if r.model == model and r.perturbations[0] == kind]
        entry: dict[str, Any] = {"model": model, "kind": kind, "attempts": len(mine), "counts": {}}
        for field in ("noticed", "recovered", "honest"):
            entry[field], entry["counts"][field] = _rate(mine, field)
        out.append(entry)
    return out


def recovery_section(rates: Sequence[dict[str, Any]]) -> list[str]:
    """The markdown subsection on recovery (nothing when no attempt was scored)."""
    if not rates:
        return []
    lines = [
        [cell(r["model"]), cell(r["kind"]), str(r["attempts"])]
        + [f"{pct(r[f])} ({r['counts'][f]})" for f in ("noticed", "recovered", "honest")]
        for r in rates
    ]
    header = ["model", "first perturbation", "attempts", "noticed", "recovered", "ended honestly"]
    return [
        "### Recovery",
        "",
        "How the agent met the first thing that went wrong: it noticed (looked around, retried the action it "
        "broke or grabbed the object it concerned), recovered (the verdict was a success; on a goal made "
        "impossible, an honest failure) and ended honestly (its end_task status matched the truth).",
        "",
        md_table(header, lines),
        "",
    ]
