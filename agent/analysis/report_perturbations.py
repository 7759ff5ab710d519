"""The report's section on perturbations: per model, how the attempts in which something went wrong
in the world (`AttemptRow.perturbations`, from each trace) fared against those in which nothing did.

Errored attempts are left out, as everywhere in the report. Whether an agent noticed and recovered is
read here only by its outcome (true success, and a success claimed where the world says otherwise).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.shared.evaluation import AttemptRow


def _share(rows: Sequence[AttemptRow]) -> tuple[str, float | None]:
    wins = sum(bool(r.true_success) for r in rows)
    return (f"{wins}/{len(rows)}", wins / len(rows) if rows else None)


def perturbation_scores(rows: Sequence[AttemptRow]) -> list[dict[str, Any]]:
    """Per model (in order of appearance): attempts, perturbed attempts and their kinds, true success
    with and without a perturbation, and false success claims among the perturbed attempts."""
    counted = [r for r in rows if r.outcome != "error"]
    if not any(r.perturbations for r in counted):
        return []
    out = []
    for model in dict.fromkeys(r.model for r in counted):
        mine = [r for r in counted if r.model == model]
        hit = [r for r in mine if r.perturbations]
        calm = [r for r in mine if not r.perturbations]
        claimed = [r for r in hit if r.believed_success and not r.true_success]
        out.append(
            {
                "model": model,
                "attempts": len(mine),
                "perturbed": len(hit),
                "kinds": dict(Counter(kind for r in hit for kind in r.perturbations)),
                "success_perturbed": _share(hit)[1],
                "success_unperturbed": _share(calm)[1],
                "false_success_perturbed": len(claimed) / len(hit) if hit else None,
                "counts": {"perturbed": _share(hit)[0], "unperturbed": _share(calm)[0], "false": len(claimed)},
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
        "blocked corridor; see the traces' `perturbation` events) against those in which it did not.",
        "",
        md_table(header, lines),
        "",
    ]
