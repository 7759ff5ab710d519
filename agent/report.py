"""`robocog report`: the paper's tables and figures (and more) from a results file.

- Success per model and task with Wilson 95% intervals (the paper's Tables I and II).
- Confusion matrices of believed against actual success (its Fig. 3). A task the agent never
  ended counts as believed failure (it claimed nothing), and is also counted apart.
- Success rate and mean tool calls against the memory iteration, with 95% intervals (Figs. 4, 5).
- pass^k: the chance that k independent trials all succeed, averaged over memory iterations.
- Tokens, cost and latency per model and task.
Outputs `report.md` (tables, with the PNG figures embedded), the figures, `summary.json`, and
`results.csv` in the published implementation's columns. The numbers come from
`robocog.agent.stats`, the figures from `robocog.agent.figures`.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from robocog.agent.figures import FigureFiles, draw_figures
from robocog.agent.stats import (
    PASS_KS,
    Cell,
    Confusion,
    IterationPoint,
    Summary,
    TableRow,
    confusion,
    mean_interval,
    pass_hat_k,
    summarise,
    wilson,
)
from robocog.shared.evaluation import AttemptRow

# The statistics stay importable from here, where they used to live.
__all__ = [
    "Cell",
    "Confusion",
    "IterationPoint",
    "Summary",
    "TableRow",
    "confusion",
    "load_rows",
    "markdown",
    "mean_interval",
    "pass_hat_k",
    "render",
    "summarise",
    "wilson",
    "write_csv",
]


def _pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.1f}%"


def _md_table(header: list[str], lines: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)


def write_csv(rows: list[AttemptRow], path: Path) -> None:
    """The published implementation's columns, so results can be compared with theirs."""
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(
            ["Model", "Memory", "Task", "Trial", "Invokes", "Toolcalls", "Belief", "Truth", "Accuracy", "Stopped"]
        )
        for r in rows:
            w.writerow(
                [
                    r.model,
                    r.memory_iteration,
                    r.task,
                    r.trial,
                    r.invocations,
                    r.tool_calls,
                    r.believed_success is True,
                    r.true_success,
                    r.agreement,
                    r.stopped,
                ]
            )


# --- the sections of report.md ------------------------------------------------------------------


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
            r.model,
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


def _belief(summary: Summary, figures: FigureFiles) -> list[str]:
    header = [
        "model",
        "believed ✓ / actual ✓",
        "believed ✓ / actual ✗ (hallucinated)",
        "believed ✗ / actual ✓",
        "believed ✗ / actual ✗",
    ]
    lines = [[m, str(c.tp), str(c.fp), str(c.fn), str(c.tn)] for m, c in summary.confusion.items()]
    return [
        "## Believed against actual success",
        "",
        "Rows: what the agent reported with end_task; columns: the world's verdict. A task never ended "
        "counts as believed failure.",
        "",
        f"![confusion matrices]({figures.confusion})",
        "",
        _md_table(header, lines),
        "",
    ]


def _memory_line(r: TableRow, p: IterationPoint) -> list[str]:
    return [
        r.model,
        r.task,
        str(p.memory_iteration),
        str(p.n),
        f"{_pct(p.rate)} ({_pct(p.rate_ci[0])} – {_pct(p.rate_ci[1])})",
        f"{p.tool_calls:.1f} ({p.tool_calls_ci[0]:.1f} – {p.tool_calls_ci[1]:.1f})",
    ]


def _memory(summary: Summary, figures: FigureFiles) -> list[str]:
    lines = [_memory_line(r, p) for r in summary.table for p in r.by_memory_iteration]
    return [
        "## Memory",
        "",
        f"![success against memory iteration]({figures.rate})",
        "",
        f"![tool calls against memory iteration]({figures.tool_calls})",
        "",
        _md_table(["model", "task", "memory iteration", "n", "success (95% CI)", "tool calls (95% CI)"], lines),
        "",
    ]


def _consistency(summary: Summary) -> list[str]:
    ks = [k for k in PASS_KS if any(k in r.pass_hat for r in summary.table)]
    lines = [[r.model, r.task, *[_pct(r.pass_hat[k]) if k in r.pass_hat else "n/a" for k in ks]] for r in summary.table]
    return [
        "## Consistency across trials (pass^k)",
        "",
        "The chance that k trials at the same memory iteration all succeed, averaged over iterations.",
        "",
        _md_table(["model", "task", *[f"pass^{k}" for k in ks]], lines),
        "",
    ]


def _cost(summary: Summary) -> list[str]:
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
            r.model,
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
    return [
        "## Cost",
        "",
        _md_table(header, lines),
        "",
        "Means per attempt unless noted. `results.csv` has every attempt in the published implementation's "
        "columns; `summary.json` has every number above.",
        "",
    ]


def markdown(summary: Summary, figures: FigureFiles, *, title: str) -> str:
    """The text of report.md."""
    parts = [
        f"# {title}",
        "",
        f"{summary.attempts} attempts; models: {', '.join(summary.models)}; tasks: {', '.join(summary.tasks)}.",
        "",
    ]
    for t in summary.tasks:
        parts += _success(summary, t)
    parts += _belief(summary, figures)
    parts += _memory(summary, figures)
    parts += _consistency(summary)
    parts += _cost(summary)
    return "\n".join(parts)


def render(rows: list[AttemptRow], out: Path, *, title: str = "robocog evaluation") -> Path:
    """Write report.md, the figures, summary.json and results.csv into `out`; returns report.md."""
    if not rows:
        raise ValueError("the results file holds no attempts")
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(rows)
    (out / "summary.json").write_text(json.dumps(summary.as_json(), indent=2), encoding="utf-8")
    write_csv(rows, out / "results.csv")
    figures = draw_figures(summary, out)
    report = out / "report.md"
    report.write_text(markdown(summary, figures, title=title), encoding="utf-8")
    return report


def load_rows(path: Path) -> list[AttemptRow]:
    """The attempts of a results file written by `robocog eval`."""
    from robocog.agent.evaluation import read_rows

    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results file")
    return read_rows(path)
