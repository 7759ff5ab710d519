"""The paper's figures, drawn as the paper draws them (our own code, from the figures' design):

- Fig. 3: per model, a 2x2 heatmap of the ground truth (rows: failure, success) against the belief
  (columns: failure, success), row-normalised percentages with the counts in the cells; tasks and
  memory iterations pooled, stopped attempts left out.
- Fig. 4: per model, grouped bars of the success percentage: x = task, one bar per memory iteration,
  value labels on the bars; stopped attempts included (as failures).
- Fig. 5: per model, box plots of the tool calls: grouped by task, one box per memory iteration;
  stopped attempts left out. A box of fewer than ten attempts also shows them as dots (then
  without the separate outlier markers).

Errored attempts are in none of them. matplotlib is imported when a figure is drawn.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from robocog.agent.analysis.figure_layout import iteration_colour, legend_below, new_figure, panel_size, panels
from robocog.agent.analysis.stats import IterationPoint, Summary

# The paper's box medians.
_MEDIAN = "cyan"
# Boxes of fewer attempts than this also show the attempts as dots (a box of two says little).
_DOTS_BELOW = 10


def draw_paper_confusion(summary: Summary, path: Path) -> None:
    """Fig. 3: per model, actual (rows) x believed (columns), row percentages and counts."""
    import matplotlib
    import numpy as np

    models = summary.reported_models
    fig = new_figure(*panel_size(len(models), 3.3, 3.1))
    cmap = matplotlib.colormaps["Blues"].with_extremes(bad="#e6e6e6")
    image = None
    for ax, m in zip(panels(fig, len(models)), models, strict=True):
        c = summary.paper_confusion[m]
        shares = [[math.nan if s is None else 100 * s for s in row] for row in c.shares]
        image = ax.imshow(np.ma.masked_invalid(np.array(shares)), cmap=cmap, vmin=0, vmax=100)
        for y, (row_counts, row_shares) in enumerate(zip(c.counts, c.shares, strict=True)):
            for x in range(2):
                share = row_shares[x]
                text = f"n/a\n({row_counts[x]})" if share is None else f"{100 * share:.1f}%\n({row_counts[x]})"
                colour = "white" if share is not None and share > 0.6 else "black"
                ax.text(x, y, text, ha="center", va="center", fontsize=11, color=colour)
        ax.set_xticks([0, 1], ["Failure", "Success"])
        ax.set_yticks([0, 1], ["Failure", "Success"])
        ax.set_xlabel("believed (end_task's status)", fontsize=9)
        ax.set_ylabel("actual (ground truth)", fontsize=9)
        ax.set_title(f"{m}  (n = {c.n})", fontsize=10)
    if image is not None:
        bar = fig.colorbar(image, ax=fig.axes, shrink=0.8, pad=0.02)
        bar.set_label("% of the row", fontsize=8)
    fig.suptitle(
        "Believed vs. actual success (the paper's Fig. 3): row percentages (counts)\n"
        "T1 and T2, all memory iterations; stopped and errored attempts left out",
        fontsize=10,
    )
    fig.savefig(path)


def _task_label(summary: Summary, model: str, task: str, *, ended_only: bool = False) -> str:
    """A task's tick label with its number of attempts (or of those that ended)."""
    row = summary.row(model, task)
    if row is None:
        return f"{task}\n(n = 0)"
    if ended_only:
        return f"{task}\n(n = {sum(len(p.ended_tool_calls) for p in row.by_memory_iteration)})"
    return f"{task}\n(n = {row.executions})"


def _bar_panel_width(summary: Summary) -> float:
    """Wide enough for a horizontal value label over every bar."""
    return max(3.6, 0.5 * len(summary.tasks) * max(1, len(summary.memory_iterations)) + 0.9)


def _slot_width(summary: Summary) -> float:
    """The width of a slot: a task's group (0.8 wide) holds one per memory iteration."""
    return 0.8 / max(1, len(summary.memory_iterations))


def _slots(summary: Summary, model: str) -> Iterator[tuple[int, float, IterationPoint | None]]:
    """A model's slots, iteration by iteration, task by task: the memory iteration, the slot's
    centre and its attempts (None: none)."""
    width = _slot_width(summary)
    for j, i in enumerate(summary.memory_iterations):
        for k, t in enumerate(summary.tasks):
            row = summary.row(model, t)
            yield i, k - 0.4 + width * (j + 0.5), row.point(i) if row else None


def _style_panel(ax: Any, model: str, tick_labels: list[str], ylabel: str) -> None:
    """A model's panel of Fig. 4 or 5: a tick under each task's group, the model as its title, a
    horizontal grid behind the marks."""
    ax.set_xticks(range(len(tick_labels)), tick_labels)
    ax.set_xlim(-0.5, len(tick_labels) - 0.5)
    ax.set_ylabel(ylabel)
    ax.set_title(model, fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    ax.set_axisbelow(True)


def draw_paper_success(summary: Summary, path: Path) -> None:
    """Fig. 4: per model, success percent as grouped bars (x = task, a bar per memory iteration)."""
    from matplotlib.patches import Patch

    models, tasks, iters = summary.reported_models, summary.tasks, summary.memory_iterations
    fig = new_figure(*panel_size(len(models), _bar_panel_width(summary), 3.3))
    width = _slot_width(summary)
    for ax, m in zip(panels(fig, len(models)), models, strict=True):
        for i, x, p in _slots(summary, m):
            if p is None:
                ax.text(x, 2, "n/a", ha="center", va="bottom", fontsize=7, rotation=90, color="grey")
                continue
            bars = ax.bar(x, 100 * p.rate, width=width * 0.95, color=iteration_colour(i))
            ax.bar_label(bars, labels=[f"{100 * p.rate:.1f}"], padding=2, fontsize=7)
        _style_panel(ax, m, [_task_label(summary, m, t) for t in tasks], "success [%]")
        ax.set_ylim(0, 110)
        ax.set_yticks(range(0, 101, 10))
    handles = [Patch(color=iteration_colour(i)) for i in iters]
    legend_below(fig, handles, [str(i) for i in iters], "memory iteration")
    fig.suptitle(
        "Success against memories (the paper's Fig. 4): stopped attempts count as failures, errored ones are left out",
        fontsize=10,
    )
    fig.savefig(path)


def draw_paper_tool_calls(summary: Summary, path: Path) -> None:
    """Fig. 5: per model, box plots of tool calls (grouped by task, a box per memory iteration)."""
    from matplotlib.patches import Patch
    from matplotlib.patheffects import Normal, Stroke
    from matplotlib.ticker import MaxNLocator

    models, tasks, iters = summary.reported_models, summary.tasks, summary.memory_iterations
    fig = new_figure(*panel_size(len(models), _bar_panel_width(summary), 3.3))
    width = _slot_width(summary)
    for ax, m in zip(panels(fig, len(models)), models, strict=True):
        top = 1
        for i, x, p in _slots(summary, m):
            if p is None or not p.ended_tool_calls:
                ax.text(x, 0.5, "n/a", ha="center", va="bottom", fontsize=7, rotation=90, color="grey")
                continue
            top = max(top, *p.ended_tool_calls)
            dots = len(p.ended_tool_calls) < _DOTS_BELOW
            box = ax.boxplot(
                [list(p.ended_tool_calls)],
                positions=[x],
                widths=width * 0.8,
                patch_artist=True,
                manage_ticks=False,
                showfliers=not dots,  # the dots show every attempt, outliers included
                medianprops={"color": _MEDIAN, "linewidth": 1.5},
                flierprops={"marker": "o", "markersize": 3},
            )
            for patch in box["boxes"]:
                patch.set_facecolor(iteration_colour(i))
                patch.set_alpha(0.85)
            for median in box["medians"]:
                median.set_path_effects([Stroke(linewidth=3, foreground="black"), Normal()])
            if not dots:
                continue
            # The attempts themselves, so a box of one or two attempts still shows its colour.
            count = len(p.ended_tool_calls)
            spread = [width * 0.5 * ((n + 0.5) / count - 0.5) for n in range(count)]
            ax.scatter(
                [x + d for d in spread],
                p.ended_tool_calls,
                s=9,
                color=iteration_colour(i),
                edgecolors="black",
                linewidths=0.4,
                zorder=3,
            )
        _style_panel(ax, m, [_task_label(summary, m, t, ended_only=True) for t in tasks], "tool calls")
        ax.set_ylim(0, top * 1.12 + 1)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    handles = [Patch(facecolor=iteration_colour(i)) for i in iters]
    legend_below(fig, handles, [str(i) for i in iters], "memory iteration")
    fig.suptitle(
        "Tool calls against memories (the paper's Fig. 5): attempts that ended (dots where fewer than "
        f"{_DOTS_BELOW}); stopped and errored ones left out",
        fontsize=10,
    )
    fig.savefig(path)
