"""`robocog report`: the paper's tables and figures (and more) from a results file.

- Success per model and task with Wilson 95% intervals (the paper's Tables I and II).
- Confusion matrices of believed against actual success (its Fig. 3). A task the agent never
  ended counts as believed failure (it claimed nothing), and is also counted apart.
- Success rate and mean tool calls against the memory iteration, with 95% intervals (Figs. 4, 5).
- pass^k: the chance that k independent trials all succeed, C(c, k) / C(n, k) over the n trials
  at each memory iteration, averaged over iterations.
- Tokens, cost and latency per model and task.
Outputs `report.md` (tables, with the PNG figures embedded), the figures, `summary.json`, and
`results.csv` in the published implementation's columns.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from statistics import mean, stdev

from robocog.shared.evaluation import AttemptRow

Z95 = 1.959963984540054
# Two-sided 95% quantiles of Student's t for small samples (df 1..30); the normal beyond.
_T95 = [
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
]


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def mean_interval(values: list[float]) -> tuple[float, float, float]:
    """Mean and its 95% t interval."""
    if not values:
        return (math.nan, math.nan, math.nan)
    m = mean(values)
    if len(values) < 2:
        return (m, m, m)
    t = _T95[len(values) - 2] if len(values) - 1 <= len(_T95) else Z95
    half = t * stdev(values) / math.sqrt(len(values))
    return (m, m - half, m + half)


def pass_hat_k(successes: int, n: int, k: int) -> float:
    """Unbiased estimate that k trials drawn without replacement all succeed."""
    if k > n:
        return math.nan
    return math.comb(successes, k) / math.comb(n, k)


@dataclass
class Cell:
    """Aggregates of one group of attempts."""

    n: int
    successes: int
    believed: int
    agreements: int
    stopped: int
    tool_calls: float
    tokens_in: float
    tokens_out: float
    cost: float | None
    llm_latency_s: float
    wall_s: float

    @classmethod
    def of(cls, rows: list[AttemptRow]) -> Cell:
        costs = [r.cost for r in rows if r.cost is not None]
        return cls(
            n=len(rows),
            successes=sum(r.true_success for r in rows),
            believed=sum(r.believed_success is True for r in rows),
            agreements=sum(r.agreement for r in rows),
            stopped=sum(r.stopped for r in rows),
            tool_calls=mean(r.tool_calls for r in rows),
            tokens_in=mean(r.tokens_in for r in rows),
            tokens_out=mean(r.tokens_out for r in rows),
            cost=sum(costs) if costs else None,
            llm_latency_s=mean(r.llm_latency_s for r in rows),
            wall_s=mean(r.wall_s for r in rows),
        )

    @property
    def rate(self) -> float:
        return self.successes / self.n if self.n else math.nan


def _order(values: list[str]) -> list[str]:
    return list(dict.fromkeys(values))


def _pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.1f}%"


def confusion(rows: list[AttemptRow]) -> dict[str, int]:
    """Counts of (believed, actual): tp, fp (hallucinated success), fn, tn."""
    out = {"tp": 0, "fp": 0, "fn": 0, "tn": 0}
    for r in rows:
        believed = r.believed_success is True
        key = ("t" if believed == r.true_success else "f") + ("p" if believed else "n")
        out[key] += 1
    return out


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


def summarise(rows: list[AttemptRow]) -> dict[str, object]:
    """Every number the report shows, as data."""
    models = _order([r.model for r in rows])
    tasks = _order([r.task for r in rows])
    groups: dict[tuple[str, str], list[AttemptRow]] = defaultdict(list)
    by_iter: dict[tuple[str, str, int], list[AttemptRow]] = defaultdict(list)
    for r in rows:
        groups[(r.model, r.task)].append(r)
        by_iter[(r.model, r.task, r.memory_iteration)].append(r)
    table = []
    for m in models:
        for t in tasks:
            g = groups.get((m, t))
            if not g:
                continue
            c = Cell.of(g)
            lo, hi = wilson(c.successes, c.n)
            iters = sorted({r.memory_iteration for r in g})
            pk: dict[str, float] = {}
            for k in (1, 2, 4, 8):
                values = []
                for i in iters:
                    sub = by_iter[(m, t, i)]
                    if len(sub) >= k:
                        values.append(pass_hat_k(sum(r.true_success for r in sub), len(sub), k))
                if values:
                    pk[f"pass^{k}"] = round(mean(values), 4)
            per_iter = []
            for i in iters:
                sub = by_iter[(m, t, i)]
                s = sum(r.true_success for r in sub)
                ilo, ihi = wilson(s, len(sub))
                tm, tlo, thi = mean_interval([float(r.tool_calls) for r in sub])
                per_iter.append(
                    {
                        "memory_iteration": i,
                        "n": len(sub),
                        "successes": s,
                        "rate": s / len(sub),
                        "rate_ci": [ilo, ihi],
                        "tool_calls": tm,
                        "tool_calls_ci": [tlo, thi],
                    }
                )
            table.append(
                {
                    "model": m,
                    "task": t,
                    "executions": c.n,
                    "successes": c.successes,
                    "rate": c.rate,
                    "rate_ci": [lo, hi],
                    "believed": c.believed,
                    "agreement": c.agreements / c.n,
                    "stopped": c.stopped,
                    "tool_calls": c.tool_calls,
                    "tokens_in": c.tokens_in,
                    "tokens_out": c.tokens_out,
                    "cost": c.cost,
                    "llm_latency_s": c.llm_latency_s,
                    "wall_s": c.wall_s,
                    "confusion": confusion(g),
                    **pk,
                    "by_memory_iteration": per_iter,
                }
            )
    overall = {m: confusion([r for r in rows if r.model == m]) for m in models}
    return {"models": models, "tasks": tasks, "attempts": len(rows), "table": table, "confusion": overall}


# --- figures ---------------------------------------------------------------------------------------


def _figures(summary: dict[str, object], out: Path) -> dict[str, str]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    files: dict[str, str] = {}
    models: list[str] = summary["models"]  # type: ignore[assignment]
    tasks: list[str] = summary["tasks"]  # type: ignore[assignment]
    table: list[dict] = summary["table"]  # type: ignore[assignment]

    # Confusion matrices, one panel per model (believed x actual).
    fig = Figure(figsize=(3.2 * len(models), 3.3), dpi=110)
    FigureCanvasAgg(fig)
    for i, m in enumerate(models):
        ax = fig.add_subplot(1, len(models), i + 1)
        c = summary["confusion"][m]  # type: ignore[index]
        grid = [[c["tp"], c["fp"]], [c["fn"], c["tn"]]]  # rows: believed success / failure
        top = max(max(row) for row in grid) or 1
        ax.imshow(grid, cmap="Blues", vmin=0, vmax=top)
        for y in range(2):
            for x in range(2):
                color = "white" if grid[y][x] > top / 2 else "black"
                ax.text(x, y, str(grid[y][x]), ha="center", va="center", fontsize=13, weight="bold", color=color)
        ax.set_xticks([0, 1], ["actual\nsuccess", "actual\nfailure"])
        ax.set_yticks([0, 1], ["believed\nsuccess", "believed\nfailure"])
        ax.set_title(m, fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "confusion.png")
    files["confusion"] = "confusion.png"

    # Success rate and tool calls against the memory iteration, one panel per task.
    for key, label, name in (
        ("rate", "ground-truth success rate", "memory_success.png"),
        ("tool_calls", "tool calls per attempt", "memory_tool_calls.png"),
    ):
        fig = Figure(figsize=(4.6 * len(tasks), 3.6), dpi=110)
        FigureCanvasAgg(fig)
        for i, t in enumerate(tasks):
            ax = fig.add_subplot(1, len(tasks), i + 1)
            rows_t = [r for r in table if r["task"] == t]
            for j, row in enumerate(rows_t):
                its = row["by_memory_iteration"]
                dodge = 0.06 * (j - (len(rows_t) - 1) / 2)  # keep the models' interval bars apart
                x = [p["memory_iteration"] + dodge for p in its]
                y = [p[key] for p in its]
                lo = [max(0.0, p[key] - p[f"{key}_ci"][0]) for p in its]
                hi = [max(0.0, p[f"{key}_ci"][1] - p[key]) for p in its]
                ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3, label=row["model"])
            ax.set_title(t)
            ax.set_xticks(
                sorted({p["memory_iteration"] for r in table if r["task"] == t for p in r["by_memory_iteration"]})
            )
            ax.set_xlabel("memory iteration")
            ax.set_ylabel(label)
            if key == "rate":
                ax.set_ylim(-0.05, 1.05)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / name)
        files[key] = name
    return files


# --- the report --------------------------------------------------------------------------------------


def _md_table(header: list[str], lines: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)


def render(rows: list[AttemptRow], out: Path, *, title: str = "robocog evaluation") -> Path:
    """Write report.md, the figures, summary.json and results.csv into `out`; returns report.md."""
    if not rows:
        raise ValueError("the results file holds no attempts")
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2), encoding="utf-8")
    write_csv(rows, out / "results.csv")
    figures = _figures(summary, out)
    table: list[dict] = summary["table"]  # type: ignore[assignment]
    tasks: list[str] = summary["tasks"]  # type: ignore[assignment]
    parts = [
        f"# {title}",
        "",
        f"{summary['attempts']} attempts; models: {', '.join(summary['models'])}; tasks: {', '.join(tasks)}.",
        "",
    ]
    for t in tasks:
        parts += [
            f"## Success on {t}",
            "",
            _md_table(
                [
                    "model",
                    "# executions",
                    "success rate",
                    "95% CI (Wilson)",
                    "believed success",
                    "belief = truth",
                    "never ended",
                ],
                [
                    [
                        r["model"],
                        str(r["executions"]),
                        _pct(r["rate"]),
                        f"{_pct(r['rate_ci'][0])} – {_pct(r['rate_ci'][1])}",
                        str(r["believed"]),
                        _pct(r["agreement"]),
                        str(r["stopped"]),
                    ]
                    for r in table
                    if r["task"] == t
                ],
            ),
            "",
        ]
    parts += [
        "## Believed against actual success",
        "",
        "Rows: what the agent reported with end_task; columns: the world's verdict. A task never ended "
        "counts as believed failure.",
        "",
        f"![confusion matrices]({figures['confusion']})",
        "",
        _md_table(
            [
                "model",
                "believed ✓ / actual ✓",
                "believed ✓ / actual ✗ (hallucinated)",
                "believed ✗ / actual ✓",
                "believed ✗ / actual ✗",
            ],
            [[m, str(c["tp"]), str(c["fp"]), str(c["fn"]), str(c["tn"])] for m, c in summary["confusion"].items()],
        ),
        "",
    ]  # type: ignore[union-attr]
    parts += [
        "## Memory",
        "",
        f"![success against memory iteration]({figures['rate']})",
        "",
        f"![tool calls against memory iteration]({figures['tool_calls']})",
        "",
    ]
    lines = []
    for r in table:
        for p in r["by_memory_iteration"]:
            lines.append(
                [
                    r["model"],
                    r["task"],
                    str(p["memory_iteration"]),
                    str(p["n"]),
                    f"{_pct(p['rate'])} ({_pct(p['rate_ci'][0])} – {_pct(p['rate_ci'][1])})",
                    f"{p['tool_calls']:.1f} ({p['tool_calls_ci'][0]:.1f} – {p['tool_calls_ci'][1]:.1f})",
                ]
            )
    parts += [
        _md_table(["model", "task", "memory iteration", "n", "success (95% CI)", "tool calls (95% CI)"], lines),
        "",
    ]
    ks = [k for k in ("pass^1", "pass^2", "pass^4", "pass^8") if any(k in r for r in table)]
    parts += [
        "## Consistency across trials (pass^k)",
        "",
        "The chance that k trials at the same memory iteration all succeed, averaged over iterations.",
        "",
        _md_table(
            ["model", "task", *ks],
            [[r["model"], r["task"], *[_pct(r[k]) if k in r else "n/a" for k in ks]] for r in table],
        ),
        "",
    ]
    parts += [
        "## Cost",
        "",
        _md_table(
            [
                "model",
                "task",
                "tool calls",
                "tokens in",
                "tokens out",
                "cost (total, USD)",
                "model latency (s)",
                "wall (s)",
            ],
            [
                [
                    r["model"],
                    r["task"],
                    f"{r['tool_calls']:.1f}",
                    f"{r['tokens_in']:.0f}",
                    f"{r['tokens_out']:.0f}",
                    "n/a" if r["cost"] is None else f"{r['cost']:.4f}",
                    f"{r['llm_latency_s']:.2f}",
                    f"{r['wall_s']:.2f}",
                ]
                for r in table
            ],
        ),
        "",
        "Means per attempt unless noted. `results.csv` has every attempt in the published implementation's "
        "columns; `summary.json` has every number above.",
        "",
    ]
    report = out / "report.md"
    report.write_text("\n".join(parts), encoding="utf-8")
    return report


def load_rows(path: Path) -> list[AttemptRow]:
    from robocog.agent.evaluation import read_rows

    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results file")
    return read_rows(path)
