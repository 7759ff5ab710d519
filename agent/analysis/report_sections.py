"""The sections of report.md that read the summary: the protocol, the errored attempts, success per
task, believed against actual success, memory, consistency (pass^k) and cost.

Each returns its lines; `robocog.agent.analysis.report.markdown` puts them in order.
"""

from __future__ import annotations

import math

from robocog.agent.analysis.confusion import PaperConfusion
from robocog.agent.analysis.figures import FigureFiles
from robocog.agent.analysis.markdown_table import cell, code, md_table, pct
from robocog.agent.analysis.stats import PASS_KS, IterationPoint, Summary, TableRow
from robocog.agent.analysis.tables_csv import CsvFormat
from robocog.shared.evaluation import ERRORED_POLICY

_PROTOCOLS = {
    "paper": "the paper's protocol exactly: one conversation from T1 into T2, the environment description in "
    "every invocation's message, the paper-style system prompt, the scratchpad kept from T1 into T2, top-5 memory "
    "retrieval",
    "robocog": "robocog's improved protocol: a fresh conversation per task, the bare task, our system prompt, the "
    "scratchpad cleared per task, top-3 memory retrieval",
}


def protocol_section(summary: Summary) -> list[str]:
    """Which protocol produced the attempts, or the protocols side by side when mixed."""
    if len(summary.protocols) == 1:
        (name,) = summary.protocols
        return [f"**Protocol: `{name}`** — {_PROTOCOLS.get(name, name)}.", ""]
    parts = ", ".join(f"`{p}` ({n} attempts)" for p, n in summary.protocols.items())
    return [
        f"**Protocols: mixed** — {parts}. Each model is reported once per protocol, named "
        "`model (protocol)`, so the protocols stand side by side in every table and figure.",
        "",
    ]


def errored_section(summary: Summary) -> list[str]:
    """The errored attempts per model and task, or a line saying none errored."""
    if not summary.errored:
        return ["No attempt errored: every attempt counts.", "", f"*{ERRORED_POLICY}*", ""]
    lines = [
        [cell(e.model), cell(e.task), str(e.attempts), str(e.errored), f"`{code(e.first_error)}`"]
        for e in summary.errored
    ]
    return [
        "## Errored attempts",
        "",
        f"{summary.errored_total} of {summary.attempts} attempts errored. **{ERRORED_POLICY}** Every "
        "table, figure, CSV and the leaderboard below follow it.",
        "",
        md_table(["model", "task", "attempts", "errored", "first error"], lines),
        "",
    ]


def success_section(summary: Summary, task: str) -> list[str]:
    """Success on `task` per model with Wilson 95% intervals (the paper's Tables I and II)."""
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
            cell(r.model),
            str(r.executions),
            pct(r.rate),
            f"{pct(r.rate_ci[0])} – {pct(r.rate_ci[1])}",
            str(r.believed),
            pct(r.agreement),
            str(r.stopped),
        ]
        for r in summary.rows_for(task)
    ]
    return [f"## Success on {task}", "", md_table(header, lines), ""]


def _share(c: PaperConfusion, actual: int, believed: int) -> str:
    share = c.shares[actual][believed]
    count = c.counts[actual][believed]
    return f"n/a ({count})" if share is None else f"{pct(share)} ({count})"


def belief_section(summary: Summary, figures: FigureFiles) -> list[str]:
    """Believed against actual success: the paper's Fig. 3 and our counts."""
    paper_lines = [
        [
            cell(m),
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
        [cell(m), str(c.tp), str(c.fp), str(c.fn), str(c.tn)]
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
        md_table(
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
        md_table(
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


def _bounds(ci: tuple[float, float]) -> str:
    """A mean's interval, or "no interval, n = 1" where there is none."""
    return "no interval, n = 1" if any(math.isnan(v) for v in ci) else f"{ci[0]:.1f} – {ci[1]:.1f}"


def _memory_line(r: TableRow, p: IterationPoint) -> list[str]:
    return [
        cell(r.model),
        r.task,
        str(p.memory_iteration),
        str(p.n),
        str(p.stopped),
        f"{pct(p.rate)} ({pct(p.rate_ci[0])} – {pct(p.rate_ci[1])})",
        f"{p.tool_calls:.1f} ({_bounds(p.tool_calls_ci)})",
    ]


def memory_section(summary: Summary, figures: FigureFiles) -> list[str]:
    """Success and tool calls against the memory iteration: the paper's Figs. 4 and 5, and ours."""
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
        md_table(
            ["model", "task", "memory iteration", "n", "stopped", "success (95% CI)", "tool calls (95% CI)"], lines
        ),
        "",
    ]


def consistency_section(summary: Summary) -> list[str]:
    """pass^k per model and task (none for a suite family: its pass^k is per instance)."""
    ks = [k for k in PASS_KS if any(k in r.pass_hat for r in summary.table)]
    lines = [
        [cell(r.model), r.task, *[pct(r.pass_hat[k]) if k in r.pass_hat else "n/a" for k in ks]]
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
        md_table(["model", "task", *[f"pass^{k}" for k in ks]], lines),
        "",
    ]


def cost_section(summary: Summary, csv_format: CsvFormat) -> list[str]:
    """Tool calls, tokens, cost and latency per model and task, and what the CSV holds."""
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
            cell(r.model),
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
        md_table(header, lines),
        "",
        f"Means per attempt unless noted (errored attempts left out). {csv_note}; `summary.json` has every "
        "number above.",
        "",
    ]
