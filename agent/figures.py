"""The report's figures (PNG) from a summary: confusion matrices (the paper's Fig. 3), and success
rate and tool calls against the memory iteration with 95% intervals (its Figs. 4 and 5).

matplotlib is imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robocog.agent.stats import Interval, IterationPoint, Summary

if TYPE_CHECKING:
    from matplotlib.figure import Figure


@dataclass(frozen=True)
class FigureFiles:
    """The figures' file names, relative to the report's directory."""

    confusion: str
    rate: str
    tool_calls: str


# A plotted quantity of an iteration point: its value and its interval.
Metric = Callable[[IterationPoint], tuple[float, Interval]]


def _figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110)
    FigureCanvasAgg(fig)
    return fig


def _confusion(summary: Summary, path: Path) -> None:
    """Confusion matrices, one panel per model (believed x actual)."""
    models = summary.models
    fig = _figure(3.2 * len(models), 3.3)
    for i, m in enumerate(models):
        ax = fig.add_subplot(1, len(models), i + 1)
        grid = summary.confusion[m].grid  # rows: believed success / failure
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
    fig.savefig(path)


def _against_memory(summary: Summary, metric: Metric, label: str, *, is_rate: bool, path: Path) -> None:
    """One quantity against the memory iteration, one panel per task, one line per model."""
    tasks = summary.tasks
    fig = _figure(4.6 * len(tasks), 3.6)
    for i, t in enumerate(tasks):
        ax = fig.add_subplot(1, len(tasks), i + 1)
        rows_t = summary.rows_for(t)
        for j, row in enumerate(rows_t):
            its = row.by_memory_iteration
            dodge = 0.06 * (j - (len(rows_t) - 1) / 2)  # keep the models' interval bars apart
            values = [metric(p) for p in its]
            x = [p.memory_iteration + dodge for p in its]
            y = [v for v, _ in values]
            lo = [max(0.0, v - ci[0]) for v, ci in values]
            hi = [max(0.0, ci[1] - v) for v, ci in values]
            ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3, label=row.model)
        ax.set_title(t)
        ax.set_xticks(sorted({p.memory_iteration for r in rows_t for p in r.by_memory_iteration}))
        ax.set_xlabel("memory iteration")
        ax.set_ylabel(label)
        if is_rate:
            ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def draw_figures(summary: Summary, out: Path) -> FigureFiles:
    """Draw every figure of the report into `out`; returns their file names."""
    files = FigureFiles(confusion="confusion.png", rate="memory_success.png", tool_calls="memory_tool_calls.png")
    _confusion(summary, out / files.confusion)
    _against_memory(
        summary,
        lambda p: (p.rate, p.rate_ci),
        "ground-truth success rate",
        is_rate=True,
        path=out / files.rate,
    )
    _against_memory(
        summary,
        lambda p: (p.tool_calls, p.tool_calls_ci),
        "tool calls per attempt",
        is_rate=False,
        path=out / files.tool_calls,
    )
    return files
