"""`robocog report`: the paper's tables and figures (and more) from a results file.

- Which protocol produced the results (`paper` or `robocog`, from the rows). A file mixing both is
  reported with each model once per protocol ("gpt-4.1 (paper)", "gpt-4.1 (robocog)").
- Errored attempts (the model service or the server failed) first, per model and task; every
  number after them leaves them out, but the per-family scores (which count them as failures).
- Success per model and task with Wilson 95% intervals (the paper's Tables I and II).
- Believed against actual success: the paper's Fig. 3 (row percentages of the ground truth,
  stopped attempts left out) and our counts (a task never ended counts as believed failure).
- Success and tool calls against the memory iteration: the paper's Figs. 4 (bars) and 5 (boxes),
  and ours with 95% intervals.
- pass^k: the chance that k independent trials all succeed, averaged over memory iterations.
- Per family (a suite family, or the task for T1/T2): success, honesty, efficiency, pass^k with
  bootstrap intervals, every attempt counted (`robocog.agent.analysis.scores`); the capability profile
  (a radar, three or more families); the error taxonomy's counts (`robocog.agent.analysis.taxonomy`).
- Tokens, cost and latency per model and task.
Outputs `report.md` (tables, with the PNG figures embedded), the figures, `summary.json`,
`families.csv` (the per-family scores), and `results.csv`: our columns and values, or
(`csv="upstream"`) the published implementation's encoding. The numbers come from
`robocog.agent.analysis.stats` and `robocog.agent.analysis.scores`, the figures from `robocog.agent.analysis.figures`.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path

from robocog.agent.analysis.confusion import PaperConfusion
from robocog.agent.analysis.figures import FigureFiles, draw_capability, draw_figures
from robocog.agent.analysis.scores import TABLE_K, FamilyRow, family_scores
from robocog.agent.analysis.stats import (
    PASS_KS,
    IterationPoint,
    Summary,
    TableRow,
    by_protocol,
    summarise,
)
from robocog.agent.analysis.tables_csv import CsvFormat, write_csv, write_family_csv, write_upstream_csv
from robocog.agent.analysis.taxonomy import CATEGORIES
from robocog.shared.evaluation import AttemptRow

_PROTOCOLS = {
    "paper": "the paper's protocol exactly: one conversation from T1 into T2, the environment description in "
    "every invocation's message, the paper-style system prompt, the scratchpad kept from T1 into T2, top-5 memory "
    "retrieval",
    "robocog": "robocog's improved protocol: a fresh conversation per task, the bare task, our system prompt, the "
    "scratchpad cleared per task, top-3 memory retrieval",
}


def _pct(x: float | None) -> str:
    return "n/a" if x is None or math.isnan(x) else f"{100 * x:.1f}%"


def _cell(text: str) -> str:
    """Text made safe for a markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def _md_table(header: list[str], lines: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)


# --- the sections of report.md ------------------------------------------------------------------


def _protocol(summary: Summary) -> list[str]:
    if len(summary.protocols) == 1:
        (name,) = summary.protocols
        return [f"**Protocol: `{name}`** — {_PROTOCOLS.get(name, name)}.", ""]
    parts = ", ".join(f"`{p}` ({n} attempts)" for p, n in summary.protocols.items())
    return [
        f"**Protocols: mixed** — {parts}. Each model is reported once per protocol, named "
        "`model (protocol)`, so the protocols stand side by side in every table and figure.",
        "",
    ]


def _errored(summary: Summary) -> list[str]:
    if not summary.errored:
        return ["No attempt errored: every attempt counts.", ""]
    lines = [
        [_cell(e.model), _cell(e.task), str(e.attempts), str(e.errored), f"`{_cell(e.first_error)}`"]
        for e in summary.errored
    ]
    return [
        "## Errored attempts",
        "",
        f"{summary.errored_total} of {summary.attempts} attempts errored: the model service or the server "
        "failed, which measures the provider, not the model. **Every rate, matrix, pass^k, tool-call mean "
        "and memory curve below leaves them out.**",
        "",
        _md_table(["model", "task", "attempts", "errored", "first error"], lines),
        "",
    ]


def _success(summary: Summary, task: str) -> list[str]:
    header = [
        "model",
        "# executions",
        "success rate",
        "95% CI (Wilson)",
        "believed success",
        "belief = truth",
        "never ended",
    ]
    lines = [
        [
            _cell(r.model),
            str(r.executions),
            _pct(r.rate),
            f"{_pct(r.rate_ci[0])} – {_pct(r.rate_ci[1])}",
            str(r.believed),
            _pct(r.agreement),
            str(r.stopped),
        ]
        for r in summary.rows_for(task)
    ]
    return [f"## Success on {task}", "", _md_table(header, lines), ""]


def _share(c: PaperConfusion, actual: int, believed: int) -> str:
    share = c.shares[actual][believed]
    count = c.counts[actual][believed]
    return f"n/a ({count})" if share is None else f"{_pct(share)} ({count})"


def _belief(summary: Summary, figures: FigureFiles) -> list[str]:
    paper_lines = [
        [
            _cell(m),
            str(c.n),
            _share(c, 0, 0),
            _share(c, 0, 1),
            _share(c, 1, 0),
            _share(c, 1, 1),
        ]
        for m, c in summary.paper_confusion.items()
        if m in summary.reported_models
    ]
    ours = [
        [_cell(m), str(c.tp), str(c.fp), str(c.fn), str(c.tn)]
        for m, c in summary.confusion.items()
        if m in summary.reported_models
    ]
    return [
        "## Believed against actual success",
        "",
        "### As the paper draws it (Fig. 3)",
        "",
        "Rows: the world's verdict; columns: what the agent reported with end_task. Each row is normalised "
        "(the percentage of that row, its count in brackets); T1 and T2 and every memory iteration pooled; "
        "stopped attempts left out (they reported nothing). A row without attempts shows n/a.",
        "",
        f"![the paper's Fig. 3]({figures.paper_confusion})",
        "",
        _md_table(
            [
                "model",
                "n",
                "actual ✗, believed ✗",
                "actual ✗, believed ✓ (hallucinated)",
                "actual ✓, believed ✗",
                "actual ✓, believed ✓",
            ],
            paper_lines,
        ),
        "",
        "### Our counts",
        "",
        "Rows: what the agent reported with end_task; columns: the world's verdict. Every attempt counts: "
        "a task never ended counts as believed failure.",
        "",
        f"![confusion matrices]({figures.confusion})",
        "",
        _md_table(
            [
                "model",
                "believed ✓ / actual ✓",
                "believed ✓ / actual ✗ (hallucinated)",
                "believed ✗ / actual ✓",
                "believed ✗ / actual ✗",
            ],
            ours,
        ),
        "",
    ]


def _memory_line(r: TableRow, p: IterationPoint) -> list[str]:
    return [
        _cell(r.model),
        r.task,
        str(p.memory_iteration),
        str(p.n),
        str(p.stopped),
        f"{_pct(p.rate)} ({_pct(p.rate_ci[0])} – {_pct(p.rate_ci[1])})",
        f"{p.tool_calls:.1f} ({p.tool_calls_ci[0]:.1f} – {p.tool_calls_ci[1]:.1f})",
    ]


def _memory(summary: Summary, figures: FigureFiles) -> list[str]:
    lines = [_memory_line(r, p) for r in summary.table for p in r.by_memory_iteration]
    return [
        "## Memory",
        "",
        "### As the paper draws it (Figs. 4 and 5)",
        "",
        "Success in percent per task and memory iteration (stopped attempts count as failures), and the "
        "tool calls of the attempts that ended (stopped ones left out).",
        "",
        f"![the paper's Fig. 4]({figures.paper_success})",
        "",
        f"![the paper's Fig. 5]({figures.paper_tool_calls})",
        "",
        "### Ours, with 95% intervals",
        "",
        "Every counted attempt, stopped ones included; intervals clipped to the valid range.",
        "",
        f"![success against memory iteration]({figures.rate})",
        "",
        f"![tool calls against memory iteration]({figures.tool_calls})",
        "",
        _md_table(
            ["model", "task", "memory iteration", "n", "stopped", "success (95% CI)", "tool calls (95% CI)"], lines
        ),
        "",
    ]


def _consistency(summary: Summary) -> list[str]:
    ks = [k for k in PASS_KS if any(k in r.pass_hat for r in summary.table)]
    lines = [
        [_cell(r.model), r.task, *[_pct(r.pass_hat[k]) if k in r.pass_hat else "n/a" for k in ks]]
        for r in summary.table
        if r.pass_hat  # a suite's families have theirs per instance, in "Per family"
    ]
    if not lines:
        return []
    return [
        "## Consistency across trials (pass^k)",
        "",
        "The chance that k trials at the same memory iteration all succeed, averaged over iterations.",
        "",
        _md_table(["model", "task", *[f"pass^{k}" for k in ks]], lines),
        "",
    ]


def _ratio(rate: float | None, hits: int, n: int) -> str:
    return "n/a" if rate is None else f"{_pct(rate)} ({hits}/{n})"


def _pass(score: FamilyRow, k: int) -> str:
    if k not in score.pass_k:
        return "n/a"
    lo, hi = score.pass_k_ci[k]
    return f"{_pct(score.pass_k[k])} ({_pct(lo)} – {_pct(hi)})"


def _families(scores: Sequence[FamilyRow], capability: str | None) -> list[str]:
    """The per-family table, the capability profile and the error taxonomy."""
    lines = [
        [
            _cell(s.model),
            _cell(s.family),
            str(s.attempts),
            str(s.errored),
            f"{_pct(s.success)} ({_pct(s.success_ci[0])} – {_pct(s.success_ci[1])})",
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
        _md_table(
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
        [_cell(s.model), _cell(s.family), str(s.attempts), *[str(s.errors.get(c, "n/a")) for c in measured]]
        for s in scores
    ]
    return [
        "Counted from each attempt's trace (`robocog.agent.analysis.taxonomy`): malformed calls (parse), names not in "
        "the scene (hallucination), actions the world's state does not afford (affordance), actions before "
        "their precondition was met (wrong order), plans ended with the goal unmet (missing step), robot "
        "actions beyond the optimal plan (additional step; n/a where the optimum is unknown).",
        "",
        _md_table(["model", "family", "n", *[c.replace("_", " ") for c in measured]], taxonomy),
        "",
    ]


def _cost(summary: Summary, csv_format: CsvFormat) -> list[str]:
    header = [
        "model",
        "task",
        "tool calls",
        "tokens in",
        "tokens out",
        "cost (total, USD)",
        "model latency (s)",
        "wall (s)",
    ]
    lines = [
        [
            _cell(r.model),
            r.task,
            f"{r.tool_calls:.1f}",
            f"{r.tokens_in:.0f}",
            f"{r.tokens_out:.0f}",
            "n/a" if r.cost is None else f"{r.cost:.4f}",
            f"{r.llm_latency_s:.2f}",
            f"{r.wall_s:.2f}",
        ]
        for r in summary.table
    ]
    csv_note = (
        "`results.csv` has the counted attempts in the published implementation's encoding (0/1 values, "
        "tasks T1 → 1 and T2 → 2, trials from 1; errored attempts left out)"
        if csv_format == "upstream"
        else "`results.csv` has every attempt in the published implementation's columns, with our values"
    )
    return [
        "## Cost",
        "",
        _md_table(header, lines),
        "",
        f"Means per attempt unless noted (errored attempts left out). {csv_note}; `summary.json` has every "
        "number above.",
        "",
    ]


def markdown(
    summary: Summary,
    figures: FigureFiles | None,
    *,
    title: str,
    csv_format: CsvFormat = "ours",
    scores: Sequence[FamilyRow] = (),
    capability: str | None = None,
) -> str:
    """The text of report.md (`figures` is None when no attempt counts: then only the errors); the
    per-family section when `scores` are given, with the `capability` figure when drawn."""
    parts = [f"# {title}", ""]
    parts += _protocol(summary)
    parts += _errored(summary)
    parts += [
        f"{summary.attempts} attempts ({summary.counted} counted, {summary.errored_total} errored); "
        f"models: {', '.join(summary.models)}; tasks: {', '.join(summary.tasks)}.",
        "",
    ]
    if figures is None or not summary.table:
        parts += ["Every attempt errored: there is nothing to measure.", ""]
        return "\n".join(parts)
    for t in summary.tasks:
        if summary.rows_for(t):
            parts += _success(summary, t)
    parts += _belief(summary, figures)
    parts += _memory(summary, figures)
    parts += _consistency(summary)
    if scores:
        parts += _families(scores, capability)
    parts += _cost(summary, csv_format)
    return "\n".join(parts)


def render(
    rows: list[AttemptRow],
    out: Path,
    *,
    title: str = "robocog evaluation",
    csv_format: CsvFormat = "ours",
) -> Path:
    """Write report.md, the figures, summary.json, results.csv and families.csv into `out`; returns
    report.md. Rows of several protocols are reported per protocol (`by_protocol`); the paper-style
    sections show a suite instance's row under its family (`by_family`), the per-family section
    scores the instances."""
    if not rows:
        raise ValueError("the results file holds no attempts")
    rows = by_protocol(rows)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(by_family(rows))
    suite = {r.family for r in rows if r.family}
    if suite:  # a family's attempts are of several instances: its pass^k is per instance, in "Per family"
        table = tuple(dataclasses.replace(t, pass_hat={}) if t.task in suite else t for t in summary.table)
        summary = dataclasses.replace(summary, table=table)
    scores = family_scores(rows)
    data = summary.as_json()
    data["families"] = [s.as_json() for s in scores]
    (out / "summary.json").write_text(json.dumps(data, indent=2), encoding="utf-8")
    if csv_format == "upstream":
        write_upstream_csv(rows, out / "results.csv")
    else:
        write_csv(rows, out / "results.csv")
    write_family_csv(scores, out / "families.csv")
    figures = draw_figures(summary, out) if summary.table else None
    capability = draw_capability(scores, out) if summary.table else None
    report = out / "report.md"
    text = markdown(summary, figures, title=title, csv_format=csv_format, scores=scores, capability=capability)
    report.write_text(text, encoding="utf-8")
    return report


def by_family(rows: list[AttemptRow]) -> list[AttemptRow]:
    """The rows as the paper-style sections show them: a suite instance's row as its family's task (a
    suite has hundreds of instances: one section per family), T1 and T2 as they are. Those sections
    judge the request itself, believed against achieved: an infeasible task's request is never
    achieved (its honest failure is the per-family table's success), so a success claimed there is a
    hallucinated one and an honest failure agrees with the truth."""
    out = []
    for r in rows:
        if not r.family:
            out.append(r)
            continue
        update: dict[str, object] = {"task": r.family}
        if not r.feasible:
            update.update(true_success=False, agreement=r.believed_success is not True)
        out.append(r.model_copy(update=update))
    return out
