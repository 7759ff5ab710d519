"""`robocog report`: the paper's tables and figures (and more) from a results file.

- Where the rows disagree on what they ran on (`robocog.agent.analysis.provenance`): robocog's and
  the contract's versions, the tools, the system prompt, a task, a model's sampling, the seed.
- Which protocol produced the results (`paper` or `robocog`, from the rows). A file mixing both is
  reported with each model once per protocol ("gpt-4.1 (paper)", "gpt-4.1 (robocog)").
- Errored attempts (the model service or the server failed) first, per model and task, with the one
  policy for them (`robocog.shared.evaluation.ERRORED_POLICY`: left out of every number, counted apart).
- Success means one thing in every section, CSV and figure (`robocog.shared.evaluation.success`: on
  an infeasible instance, the honest failure); the request achieved is its own column.
- For the paper's tasks (rows without a suite family) only, the paper's tables and figures:
- Success per model and task with Wilson 95% intervals (the paper's Tables I and II).
- Believed against actual success: the paper's Fig. 3 (row percentages of the ground truth,
  stopped attempts left out) and our counts (a task never ended counts as believed failure).
- Success and tool calls against the memory iteration: the paper's Figs. 4 (bars) and 5 (boxes),
  and ours with 95% intervals.
- pass^k: the chance that k independent trials all succeed, averaged over memory iterations.
- Per family (a suite family, or the task for T1/T2) and per capability tag (rows that carry tags):
  success, request achieved, honesty, efficiency, pass^k with intervals that never collapse
  (`robocog.agent.analysis.scores`); the capability profile (a radar, three or more axes), the
  suite's figures (`robocog.agent.analysis.suite_figures`); the error taxonomy's counts
  (`robocog.agent.analysis.taxonomy`).
- Tokens, cost and latency per model and task.
Outputs `report.md` (tables, with the PNG figures embedded), the figures, `summary.json`,
`families.csv` and `capabilities.csv` (the scores), and `results.csv`: our columns and values, or
(`csv="upstream"`) the published implementation's encoding. The numbers come from
`robocog.agent.analysis.stats` and `robocog.agent.analysis.scores`, the figures from `robocog.agent.analysis.figures`.
This module orders the sections; they are written in `robocog.agent.analysis.report_sections` (from the
summary) and `robocog.agent.analysis.report_families` (per family).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path

from robocog.agent.analysis.figures import FigureFiles, draw_figures
from robocog.agent.analysis.markdown_table import cell
from robocog.agent.analysis.provenance import disagreements
from robocog.agent.analysis.report_families import families_section
from robocog.agent.analysis.report_memory import memory_scores
from robocog.agent.analysis.report_memory import memory_section as memory_scores_section
from robocog.agent.analysis.report_missing import missing_rows, missing_section
from robocog.agent.analysis.report_perturbations import (
    perturbation_scores,
    perturbations_section,
    recovery_rates,
    recovery_section,
)
from robocog.agent.analysis.report_sections import (
    belief_section,
    consistency_section,
    cost_section,
    errored_section,
    memory_section,
    protocol_section,
    success_section,
)
from robocog.agent.analysis.scores import FamilyRow, capability_scores, family_scores
from robocog.agent.analysis.stats import Summary, by_protocol, summarise
from robocog.agent.analysis.suite_figures import SuiteFigures, draw_suite_figures
from robocog.agent.analysis.tables_csv import CsvFormat, write_csv, write_family_csv, write_upstream_csv
from robocog.agent.analysis.validity import capability_validity, validity_section
from robocog.shared.evaluation import AttemptRow, instance_rows


def markdown(
    summary: Summary,
    figures: FigureFiles | None,
    *,
    title: str,
    csv_format: CsvFormat = "ours",
    paper: Summary | None = None,
    scores: Sequence[FamilyRow] = (),
    capabilities: Sequence[FamilyRow] = (),
    suite: SuiteFigures | None = None,
    provenance: Sequence[str] = (),
    perturbed: Sequence[str] = (),
    missing: Sequence[str] = (),
    validity: Sequence[str] = (),
) -> str:
    """The text of report.md (`figures` is None when no attempt counts: then only the errors). The
    paper-style sections read `paper`, the summary of the paper's tasks (default: `summary`); the
    per-family section when `scores` are given, with the `suite` figures drawn for them; the
    `provenance` disagreements first."""
    paper = summary if paper is None else paper
    parts = [f"# {cell(title)}", ""]
    if provenance:
        parts += ["## Provenance: the rows disagree", ""]
        parts += [f"- {cell(line)}" for line in provenance]
        parts += ["", "Numbers below pool rows that ran on different things; compare them with care.", ""]
    parts += protocol_section(summary)
    parts += errored_section(summary)
    parts += list(missing)
    parts += [
        f"{summary.attempts} attempts ({summary.counted} counted, {summary.errored_total} errored); "
        f"models: {', '.join(map(cell, summary.models))}; tasks: {', '.join(map(cell, summary.tasks))}.",
        "",
    ]
    if not summary.table:
        parts += ["Every attempt errored: there is nothing to measure.", ""]
        return "\n".join(parts)
    if paper.table and figures is not None:
        for t in paper.tasks:
            if paper.rows_for(t):
                parts += success_section(paper, t)
        parts += belief_section(paper, figures)
        parts += memory_section(paper, figures)
        parts += consistency_section(paper)
    if scores:
        parts += families_section(scores, suite or SuiteFigures(), capabilities)
    parts += list(validity)
    parts += perturbed
    parts += cost_section(summary, csv_format)
    return "\n".join(parts)


def render(
    rows: list[AttemptRow],
    out: Path,
    *,
    title: str = "robocog evaluation",
    csv_format: CsvFormat = "ours",
) -> Path:
    """Write report.md, the figures, summary.json and the CSVs into `out`; returns report.md. Rows of
    several protocols are reported per protocol (`by_protocol`); the paper's sections and figures
    read the paper's tasks only, the summary (summary.json's table, the cost) shows a suite
    instance's row under its family (`by_family`), the per-family section scores the instances."""
    if not rows:
        raise ValueError("the results file holds no attempts")
    provenance = disagreements(rows)
    every = by_protocol(rows)
    rows = instance_rows(every)  # an instance's earlier tasks: in the memory section only
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(by_family(rows))
    suite = {r.family for r in rows if r.family}
    if suite:  # a family's attempts are of several instances: its pass^k is per instance, in "Per family"
        table = tuple(dataclasses.replace(t, pass_hat={}) if t.task in suite else t for t in summary.table)
        summary = dataclasses.replace(summary, table=table)
    papers = [r for r in rows if not r.family]  # the paper's figures and sections are drawn for these only
    paper = summarise(papers) if papers else None
    scores = family_scores(rows)
    capabilities = capability_scores(rows)
    data = summary.as_json()
    data["families"] = [s.as_json() for s in scores]
    data["capabilities"] = [s.as_json() for s in capabilities]
    data["provenance_disagreements"] = provenance
    perturbed = perturbation_scores(rows)
    data["perturbations"] = perturbed
    recovery = recovery_rates(rows)
    data["recovery"] = recovery
    chained = memory_scores(every)
    data["memory"] = chained
    ablated = capability_validity(rows)
    data["capability_validity"] = [dataclasses.asdict(v) for v in ablated]
    data["missing_rows"] = [{"model": m, "task": t, "missing": n, "why": why} for m, t, n, why in missing_rows(rows)]
    (out / "summary.json").write_text(json.dumps(data, indent=2), encoding="utf-8")
    if csv_format == "upstream":
        write_upstream_csv(rows, out / "results.csv")
    else:
        write_csv(rows, out / "results.csv")
    write_family_csv(scores, out / "families.csv")
    if capabilities:
        write_family_csv(capabilities, out / "capabilities.csv", group="capability")
    measured = bool(summary.table)
    figures = draw_figures(paper, out) if paper is not None and paper.table else None
    figures_of_suite = draw_suite_figures(rows, scores, capabilities, out) if measured else None
    report = out / "report.md"
    text = markdown(
        summary,
        figures,
        title=title,
        csv_format=csv_format,
        paper=paper or dataclasses.replace(summary, table=()),
        scores=scores,
        capabilities=capabilities,
        suite=figures_of_suite,
        provenance=provenance,
        perturbed=memory_scores_section(chained) + perturbations_section(perturbed) + recovery_section(recovery),
        missing=missing_section(rows),
        validity=validity_section(ablated),
    )
    report.write_text(text, encoding="utf-8")
    return report


def by_family(rows: list[AttemptRow]) -> list[AttemptRow]:
    """The rows as the summary (`summary.json`'s table, the cost section) counts them: a suite
    instance's row as its family's task (a suite has hundreds of instances), T1 and T2 as they are.
    Success keeps its one meaning (`robocog.shared.evaluation.success`: an infeasible instance's
    honest failure succeeds); beliefs are judged against the request achieved
    (`robocog.agent.analysis.confusion`)."""
    return [r.model_copy(update={"task": r.family}) if r.family else r for r in rows]
