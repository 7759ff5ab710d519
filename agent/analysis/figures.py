"""The report's figures (PNG) from a summary: the paper's (`robocog.agent.analysis.paper_figures`)
and ours, drawn here: the confusion counts (believed x actual, never-ended attempts counted as
believed failure), and success rate and mean tool calls against the memory iteration with 95%
intervals (clipped to the valid range). Errored attempts are in none of them. Legends sit outside
the axes. The capability profile is `robocog.agent.analysis.capability_figure`.

matplotlib is imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robocog.agent.analysis.figure_layout import TAB10, legend_below, new_figure, panel_size, panels
from robocog.agent.analysis.paper_figures import draw_paper_confusion, draw_paper_success, draw_paper_tool_calls
from robocog.agent.analysis.stats import Interval, IterationPoint, Summary

if TYPE_CHECKING:
    from matplotlib.artist import Artist


@dataclass(frozen=True)
class FigureFiles:
    """The figures' file names, relative to the report's directory."""

    paper_confusion: str
    paper_success: str
    paper_tool_calls: str
    confusion: str
    rate: str
    tool_calls: str

    @property
    def all(self) -> tuple[str, ...]:
        return (
            self.paper_confusion,
            self.paper_success,
            self.paper_tool_calls,
            self.confusion,
            self.rate,
            self.tool_calls,
        )


# A plotted quantity of an iteration point: its value and its interval.
Metric = Callable[[IterationPoint], tuple[float, Interval]]


def _confusion(summary: Summary, path: Path) -> None:
    """Our confusion counts, one panel per model (believed x actual)."""
    models = summary.reported_models
    fig = new_figure(*panel_size(len(models), 3.2, 3.0))
    for ax, m in zip(panels(fig, len(models)), models, strict=True):
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
    fig.suptitle(
        "Our counts: believed x actual success, every attempt counted\n"
        "(never ended = believed failure; errored attempts left out)",
        fontsize=10,
    )
    fig.savefig(path)


def _against_memory(summary: Summary, metric: Metric, label: str, *, title: str, is_rate: bool, path: Path) -> None:
    """One quantity against the memory iteration, one panel per task, one line per model; the
    intervals clipped to the valid range (a rate within 0..1, tool calls never below 0)."""
    tasks = summary.tasks
    fig = new_figure(4.4 * len(tasks), 3.8)
    handles: dict[str, Artist] = {}
    for i, t in enumerate(tasks):
        ax = fig.add_subplot(1, len(tasks), i + 1)
        rows_t = summary.rows_for(t)
        for j, row in enumerate(rows_t):
            its = row.by_memory_iteration
            dodge = 0.08 * (j - (len(rows_t) - 1) / 2)  # keep the models' interval bars apart
            values = [metric(p) for p in its]
            x = [p.memory_iteration + dodge for p in its]
            y = [v for v, _ in values]
            floor, ceiling = (0.0, 1.0) if is_rate else (0.0, math.inf)
            # no bar where there is no interval (a mean of one value): NaN draws none
            lo = [math.nan if math.isnan(ci[0]) else max(0.0, v - max(floor, ci[0])) for v, ci in values]
            hi = [math.nan if math.isnan(ci[1]) else max(0.0, min(ceiling, ci[1]) - v) for v, ci in values]
            colour = TAB10[summary.models.index(row.model) % len(TAB10)]
            line = ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3, color=colour, label=row.model)
            handles.setdefault(row.model, line.lines[0])  # the data line: its colour and marker
        ax.set_title(t)
        ax.set_xticks(sorted({p.memory_iteration for r in rows_t for p in r.by_memory_iteration}))
        ax.set_xlabel("memory iteration")
        ax.set_ylabel(label)
        if is_rate:
            ax.set_ylim(-0.05, 1.05)
        else:  # from 0, with room for a marker at 0
            top = max(1.0, ax.get_ylim()[1])
            ax.set_ylim(-0.03 * top, top)
        ax.grid(alpha=0.3)
    legend_below(fig, list(handles.values()), list(handles), "model")
    fig.suptitle(title, fontsize=10)
    fig.savefig(path)


def draw_figures(summary: Summary, out: Path) -> FigureFiles:
    """Draw every figure of the report into `out`; returns their file names."""
    files = FigureFiles(
        paper_confusion="paper_fig3_confusion.png",
        paper_success="paper_fig4_success.png",
        paper_tool_calls="paper_fig5_tool_calls.png",
        confusion="confusion.png",
        rate="memory_success.png",
        tool_calls="memory_tool_calls.png",
    )
    draw_paper_confusion(summary, out / files.paper_confusion)
    draw_paper_success(summary, out / files.paper_success)
    draw_paper_tool_calls(summary, out / files.paper_tool_calls)
    _confusion(summary, out / files.confusion)
    _against_memory(
        summary,
        lambda p: (p.rate, p.rate_ci),
        "ground-truth success rate (95% CI)",
        title="Ours: success rate against memory iteration, with 95% Wilson intervals (stopped attempts count)",
        is_rate=True,
        path=out / files.rate,
    )
    _against_memory(
        summary,
        lambda p: (p.tool_calls, p.tool_calls_ci),
        "tool calls per attempt (95% CI)",
        title="Ours: mean tool calls against memory iteration, with 95% t intervals clipped at 0 (stopped attempts "
        "count)",
        is_rate=False,
        path=out / files.tool_calls,
    )
    return files
