"""The report's figures (PNG) from a summary.

The paper's figures, drawn as the paper draws them (our own code, from the figures' design):

- Fig. 3: per model, a 2x2 heatmap of the ground truth (rows: failure, success) against the belief
  (columns: failure, success), row-normalised percentages with the counts in the cells; tasks and
  memory iterations pooled, stopped attempts left out.
- Fig. 4: per model, grouped bars of the success percentage: x = task, one bar per memory iteration,
  value labels on the bars; stopped attempts included (as failures).
- Fig. 5: per model, box plots of the tool calls: grouped by task, one box per memory iteration;
  stopped attempts left out. A box of fewer than ten attempts also shows them as dots (then
  without the separate outlier markers).

And ours: the confusion counts (believed x actual, never-ended attempts counted as believed
failure), and success rate and mean tool calls against the memory iteration with 95% intervals
(clipped to the valid range). Errored attempts are in none of them. Legends sit outside the axes.

The capability profile (`draw_capability`, with three or more task families): a radar, one axis
per family, one line per model, the family's success rate with every attempt counted (errored
ones as failures, as `robocog.agent.analysis.scores` scores them).

matplotlib is imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, cast

from robocog.agent.analysis.scores import FamilyRow, families, models
from robocog.agent.analysis.stats import Interval, IterationPoint, Summary

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.projections.polar import PolarAxes


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

# The paper's palette for the memory iterations (matplotlib's tab10) and its box medians.
_TAB10 = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
]
_MEDIAN = "cyan"
# Boxes of fewer attempts than this also show the attempts as dots (a box of two says little).
_DOTS_BELOW = 10


def _iteration_colour(i: int) -> str:
    return _TAB10[i % len(_TAB10)]


def _figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _grid(n: int) -> tuple[int, int]:
    """Rows and columns of n panels: one row up to three, then a near-square grid."""
    if n <= 3:
        return 1, max(n, 1)
    cols = math.ceil(math.sqrt(n))
    return math.ceil(n / cols), cols


def _panels(fig: Figure, n: int) -> list[Axes]:
    rows, cols = _grid(n)
    axes = [fig.add_subplot(rows, cols, i + 1) for i in range(n)]
    return axes


def _size(n: int, width: float, height: float) -> tuple[float, float]:
    rows, cols = _grid(n)
    return width * cols, height * rows + 0.9


def _legend_below(fig: Figure, handles: Sequence[Artist], labels: Sequence[str], title: str) -> None:
    fig.legend(
        list(handles),
        list(labels),
        title=title,
        loc="outside lower center",
        ncols=min(len(labels), 6),
        fontsize=8,
        title_fontsize=8,
        frameon=False,
    )


# --- the paper's figures ---------------------------------------------------------------------------


def _paper_confusion(summary: Summary, path: Path) -> None:
    """Fig. 3: per model, actual (rows) x believed (columns), row percentages and counts."""
    import matplotlib
    import numpy as np

    models = summary.reported_models
    fig = _figure(*_size(len(models), 3.3, 3.1))
    cmap = matplotlib.colormaps["Blues"].with_extremes(bad="#e6e6e6")
    image = None
    for ax, m in zip(_panels(fig, len(models)), models, strict=True):
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


def _paper_success(summary: Summary, path: Path) -> None:
    """Fig. 4: per model, success percent as grouped bars (x = task, a bar per memory iteration)."""
    from matplotlib.patches import Patch

    models, tasks, iters = summary.reported_models, summary.tasks, summary.memory_iterations
    fig = _figure(*_size(len(models), _bar_panel_width(summary), 3.3))
    width = 0.8 / max(1, len(iters))
    for ax, m in zip(_panels(fig, len(models)), models, strict=True):
        for j, i in enumerate(iters):
            for k, t in enumerate(tasks):
                row = summary.row(m, t)
                p = row.point(i) if row else None
                x = k - 0.4 + width * (j + 0.5)
                if p is None:
                    ax.text(x, 2, "n/a", ha="center", va="bottom", fontsize=7, rotation=90, color="grey")
                    continue
                bars = ax.bar(x, 100 * p.rate, width=width * 0.95, color=_iteration_colour(i))
                ax.bar_label(bars, labels=[f"{100 * p.rate:.1f}"], padding=2, fontsize=7)
        ax.set_xticks(range(len(tasks)), [_task_label(summary, m, t) for t in tasks])
        ax.set_xlim(-0.5, len(tasks) - 0.5)
        ax.set_ylim(0, 110)
        ax.set_yticks(range(0, 101, 10))
        ax.set_ylabel("success [%]")
        ax.set_title(m, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        ax.set_axisbelow(True)
    handles = [Patch(color=_iteration_colour(i)) for i in iters]
    _legend_below(fig, handles, [str(i) for i in iters], "memory iteration")
    fig.suptitle(
        "Success against memories (the paper's Fig. 4): stopped attempts count as failures, errored ones are left out",
        fontsize=10,
    )
    fig.savefig(path)


def _paper_tool_calls(summary: Summary, path: Path) -> None:
    """Fig. 5: per model, box plots of tool calls (grouped by task, a box per memory iteration)."""
    from matplotlib.patches import Patch
    from matplotlib.patheffects import Normal, Stroke
    from matplotlib.ticker import MaxNLocator

    models, tasks, iters = summary.reported_models, summary.tasks, summary.memory_iterations
    fig = _figure(*_size(len(models), _bar_panel_width(summary), 3.3))
    width = 0.8 / max(1, len(iters))
    for ax, m in zip(_panels(fig, len(models)), models, strict=True):
        top = 1
        for j, i in enumerate(iters):
            for k, t in enumerate(tasks):
                row = summary.row(m, t)
                p = row.point(i) if row else None
                x = k - 0.4 + width * (j + 0.5)
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
                    patch.set_facecolor(_iteration_colour(i))
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
                    color=_iteration_colour(i),
                    edgecolors="black",
                    linewidths=0.4,
                    zorder=3,
                )
        ax.set_xticks(range(len(tasks)), [_task_label(summary, m, t, ended_only=True) for t in tasks])
        ax.set_xlim(-0.5, len(tasks) - 0.5)
        ax.set_ylim(0, top * 1.12 + 1)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylabel("tool calls")
        ax.set_title(m, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        ax.set_axisbelow(True)
    handles = [Patch(facecolor=_iteration_colour(i)) for i in iters]
    _legend_below(fig, handles, [str(i) for i in iters], "memory iteration")
    fig.suptitle(
        "Tool calls against memories (the paper's Fig. 5): attempts that ended (dots where fewer than "
        f"{_DOTS_BELOW}); stopped and errored ones left out",
        fontsize=10,
    )
    fig.savefig(path)


# --- ours ----------------------------------------------------------------------------------------


def _confusion(summary: Summary, path: Path) -> None:
    """Our confusion counts, one panel per model (believed x actual)."""
    models = summary.reported_models
    fig = _figure(*_size(len(models), 3.2, 3.0))
    for ax, m in zip(_panels(fig, len(models)), models, strict=True):
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
    fig = _figure(4.4 * len(tasks), 3.8)
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
            lo = [max(0.0, v - max(floor, ci[0])) for v, ci in values]
            hi = [max(0.0, min(ceiling, ci[1]) - v) for v, ci in values]
            colour = _TAB10[summary.models.index(row.model) % len(_TAB10)]
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
    _legend_below(fig, list(handles.values()), list(handles), "model")
    fig.suptitle(title, fontsize=10)
    fig.savefig(path)


#: The capability profile needs this many families (axes) to be a polygon.
CAPABILITY_AXES = 3
CAPABILITY_FILE = "capability.png"


def draw_capability(scores: Sequence[FamilyRow], out: Path) -> str | None:
    """The capability profile: a radar with one axis per family (its success rate, errored attempts
    counted as failures; on an infeasible family the honest-failure rate) and one line per model.
    Returns the file name, or None with fewer than `CAPABILITY_AXES` families."""
    names = families(scores)
    if len(names) < CAPABILITY_AXES:
        return None
    angles = [2 * math.pi * i / len(names) for i in range(len(names))]
    fig = _figure(6.4, 5.6)
    ax = cast("PolarAxes", fig.add_subplot(1, 1, 1, projection="polar"))
    ax.set_theta_offset(math.pi / 2)  # the first family at the top, the others clockwise
    ax.set_theta_direction(-1)
    handles: list[Artist] = []
    labels: list[str] = []
    for j, model in enumerate(models(scores)):
        mine = {s.family: s for s in scores if s.model == model}
        values = [mine[f].success if f in mine else math.nan for f in names]
        ring, closed = [*angles, angles[0]], [*values, values[0]]
        colour = _TAB10[j % len(_TAB10)]
        (line,) = ax.plot(ring, closed, marker="o", color=colour, linewidth=1.8)
        ax.fill(ring, [0.0 if math.isnan(v) else v for v in closed], color=colour, alpha=0.08)
        handles.append(line)
        labels.append(model)
    ticks = []
    for f in names:
        n = max((s.attempts for s in scores if s.family == f), default=0)
        ticks.append(f"{f}\n(n = {n})")
    ax.set_xticks(angles, ticks, fontsize=8)
    ax.tick_params(axis="x", pad=12)  # the family names clear of the rim
    ax.set_ylim(0, 1)
    ax.set_yticks([0.25, 0.5, 0.75, 1.0], ["25%", "50%", "75%", "100%"], fontsize=7, color="grey")
    ax.set_rlabel_position(180 / len(names))  # between the first two axes
    ax.grid(alpha=0.4)
    _legend_below(fig, handles, labels, "model")
    fig.suptitle(
        "Capability profile: success per family (infeasible: honest failure)\n"
        "every attempt counted, errored ones as failures; n = attempts per model",
        fontsize=10,
    )
    path = out / CAPABILITY_FILE
    fig.savefig(path)
    return path.name


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
    _paper_confusion(summary, out / files.paper_confusion)
    _paper_success(summary, out / files.paper_success)
    _paper_tool_calls(summary, out / files.paper_tool_calls)
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
