"""The figures of a suite's families and capability tags, designed for them rather than borrowed from
the paper (whose Figs. 3-5 are drawn for T1 and T2 only, in `robocog.agent.analysis.paper_figures`).

- Scores per family (or per capability tag): three panels side by side, success, false-success rate
  and pass^k, each a horizontal dot plot with its 95% interval, one row per family and one marker per
  model. The families are rows, not x ticks, so their names never overprint at any count; the
  figure grows by a fixed height per family, so many families make it taller, never unreadable.
- Success against the memory iteration: small multiples, one panel per family, wrapping into rows
  of `WRAP` panels (never one long strip), drawn only when the study ran two or more iterations
  (with one, each line would be a single point).

Every number is `robocog.agent.analysis.scores`' (success as `robocog.shared.evaluation.success`
defines it), so the figures agree with the report's tables and `families.csv` by construction.
matplotlib is imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robocog.agent.analysis.capability_figure import draw_capability
from robocog.agent.analysis.figure_layout import TAB10, legend_below, new_figure
from robocog.agent.analysis.scores import TABLE_K, FamilyRow, families, family_of, models
from robocog.agent.analysis.stats import wilson
from robocog.shared.evaluation import AttemptRow, success

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FAMILIES_FILE = "suite_families.png"
CAPABILITIES_FILE = "suite_capabilities.png"
MEMORY_FILE = "suite_memory.png"
#: Panels per row of the memory figure.
WRAP = 4
#: Inches per family (row) of the score figure, and per model within it.
ROW_INCHES = 0.24
MODEL_INCHES = 0.1

Interval = tuple[float, float]
#: A panel's reading of a score: its value and interval, or None where it is not measured.
Metric = Callable[[FamilyRow], "tuple[float, Interval] | None"]


def _pass_k(scores: Sequence[FamilyRow]) -> int:
    """The k of the pass^k panel: the table's k when some score has it, else the largest measured."""
    measured = {k for s in scores for k in s.pass_k}
    return TABLE_K if TABLE_K in measured else max(measured, default=1)


def _metrics(k: int) -> list[tuple[str, Metric]]:
    """(panel title, score -> (value, interval) or None) for the three panels."""

    def succ(s: FamilyRow) -> tuple[float, Interval] | None:
        return s.success, s.success_ci

    def false(s: FamilyRow) -> tuple[float, Interval] | None:
        if s.false_success_rate is None or s.false_success_ci is None:
            return None
        return s.false_success_rate, s.false_success_ci

    def passes(s: FamilyRow) -> tuple[float, Interval] | None:
        return (s.pass_k[k], s.pass_k_ci[k]) if k in s.pass_k else None

    return [
        ("success (infeasible: honest failure)", succ),
        ("false-success rate (lower is better)", false),
        (f"pass^{k}", passes),
    ]


def score_figure_size(groups: int, n_models: int) -> tuple[float, float]:
    """Width and height in inches of the score figure for `groups` rows and `n_models` models."""
    return 11.0, 1.9 + groups * (ROW_INCHES + MODEL_INCHES * n_models)


def draw_scores(scores: Sequence[FamilyRow], path: Path, *, group: str) -> str | None:
    """`score_figure` into `path`; returns the file name, or None without scores."""
    fig = score_figure(scores, group=group)
    if fig is None:
        return None
    fig.savefig(path)
    return path.name


def score_figure(scores: Sequence[FamilyRow], *, group: str) -> Figure | None:
    """Success, false-success rate and pass^k per `group` ("family" or "capability") and model, with
    95% intervals (each panel's markers are one line per model, x = the score, in `families` order)."""
    if not scores:
        return None
    names = families(scores)
    who = models(scores)
    k = _pass_k(scores)
    fig = new_figure(*score_figure_size(len(names), len(who)))
    axes: list[Axes] = []
    for i in range(3):
        axes.append(fig.add_subplot(1, 3, i + 1, sharey=axes[0] if axes else None))
    by = {(s.model, s.family): s for s in scores}
    band = 0.7  # of a row's height, shared by its models' markers
    handles: list[Artist] = []
    for ax, (title, metric) in zip(axes, _metrics(k), strict=True):
        for j, m in enumerate(who):
            offset = (j - (len(who) - 1) / 2) * band / max(len(who), 1)
            xs, ys, lo, hi = [], [], [], []
            for y, name in enumerate(names):
                s = by.get((m, name))
                value = metric(s) if s is not None else None
                if value is None:
                    continue
                x, (low, high) = value
                xs.append(x)
                ys.append(y + offset)
                lo.append(max(0.0, x - low))
                hi.append(max(0.0, high - x))
            bars = ax.errorbar(
                xs, ys, xerr=[lo, hi], fmt="o", color=TAB10[j % len(TAB10)], markersize=4.5, capsize=2, linewidth=1
            )
            if ax is axes[0]:
                handles.append(bars.lines[0])
        ax.set_title(title, fontsize=9)
        ax.set_xlim(-0.03, 1.03)
        ax.set_xticks([0, 0.25, 0.5, 0.75, 1.0], ["0%", "25%", "50%", "75%", "100%"], fontsize=8)
        ax.grid(axis="x", alpha=0.35)
        ax.set_ylim(len(names) - 0.5, -0.5)  # the first family on top
    axes[0].set_yticks(range(len(names)), [_label(scores, n) for n in names], fontsize=8)
    for ax in axes[1:]:
        ax.tick_params(axis="y", labelleft=False)
    legend_below(fig, handles, list(who), "model")
    overlap = " (an instance counts under each of its tags)" if group == "capability" else ""
    fig.suptitle(
        f"Scores per {group}{overlap}\nerrored attempts left out; 95% intervals "
        "(Wilson; pass^k: Wilson over the instances)",
        fontsize=10,
    )
    return fig


def _label(scores: Sequence[FamilyRow], name: str) -> str:
    n = max((s.attempts for s in scores if s.family == name), default=0)
    return f"{name} (n = {n})"


def draw_memory(rows: Sequence[AttemptRow], path: Path) -> str | None:
    """`memory_figure` into `path`; returns the file name, or None when it is not drawn."""
    fig = memory_figure(rows)
    if fig is None:
        return None
    fig.savefig(path)
    return path.name


def memory_figure(rows: Sequence[AttemptRow]) -> Figure | None:
    """Success against the memory iteration, one panel per family wrapping into rows of `WRAP`, one
    line per model with Wilson intervals; None unless a suite's rows span two or more iterations."""
    suite = [r for r in rows if r.family]
    iterations = sorted({r.memory_iteration for r in suite})
    if len(iterations) < 2:
        return None
    cells: dict[tuple[str, str, int], list[bool]] = defaultdict(list)
    for r in suite:
        cells[(family_of(r), r.model, r.memory_iteration)].append(success(r))
    names = list(dict.fromkeys(family_of(r) for r in suite))
    who = list(dict.fromkeys(r.model for r in suite))
    cols = min(WRAP, len(names))
    n_rows = math.ceil(len(names) / cols)
    fig = new_figure(3.0 * cols, 2.3 * n_rows + 1.0)
    handles: list[Artist] = []
    for i, name in enumerate(names):
        ax = fig.add_subplot(n_rows, cols, i + 1)
        for j, m in enumerate(who):
            xs = [it for it in iterations if cells.get((name, m, it))]
            rates = [sum(cells[(name, m, it)]) / len(cells[(name, m, it)]) for it in xs]
            bounds = [wilson(sum(cells[(name, m, it)]), len(cells[(name, m, it)])) for it in xs]
            below = [max(0.0, r - b[0]) for r, b in zip(rates, bounds, strict=True)]
            above = [max(0.0, b[1] - r) for r, b in zip(rates, bounds, strict=True)]
            line = ax.errorbar(
                xs,
                rates,
                yerr=[below, above],
                marker="o",
                color=TAB10[j % len(TAB10)],
                markersize=3.5,
                capsize=2,
                linewidth=1.2,
            )
            if i == 0:
                handles.append(line.lines[0])
        ax.set_title(name, fontsize=9)
        ax.set_ylim(-0.05, 1.05)
        ax.set_xticks(iterations)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if i % cols == 0:
            ax.set_ylabel("success", fontsize=8)
        if i >= len(names) - cols:
            ax.set_xlabel("memory iteration", fontsize=8)
    legend_below(fig, handles, who, "model")
    fig.suptitle("Success against memory iteration per family (95% Wilson intervals)", fontsize=10)
    return fig


@dataclass(frozen=True)
class SuiteFigures:
    """The file names of the figures drawn for a study's families (None: not drawn)."""

    capability: str | None = None  # the radar: per capability tag when the rows carry tags, else per family
    families: str | None = None
    capabilities: str | None = None
    memory: str | None = None


def draw_suite_figures(
    rows: Sequence[AttemptRow], scores: Sequence[FamilyRow], tagged: Sequence[FamilyRow], out: Path
) -> SuiteFigures:
    """The figures of the per-family section into `out`: the radar (per capability when `tagged` has
    scores); for a suite's rows, the scores per family and per capability and the memory small
    multiples (the paper's T1 and T2 alone get only the radar: their figures are the paper's)."""
    radar = draw_capability(tagged, out, group="capability") if tagged else draw_capability(scores, out)
    if not any(r.family for r in rows):
        return SuiteFigures(capability=radar)
    return SuiteFigures(
        capability=radar,
        families=draw_scores(scores, out / FAMILIES_FILE, group="family"),
        capabilities=draw_scores(tagged, out / CAPABILITIES_FILE, group="capability"),
        memory=draw_memory(rows, out / MEMORY_FILE),
    )
