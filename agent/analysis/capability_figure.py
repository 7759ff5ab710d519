"""The capability profile (with three or more task families): a radar, one axis per family, one line
per model, the family's success rate as `robocog.agent.analysis.scores` scores it (errored attempts left
out: `robocog.shared.evaluation.ERRORED_POLICY`).

matplotlib is imported when the figure is drawn, not with this module.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Literal, cast

from robocog.agent.analysis.figure_layout import TAB10, legend_below, new_figure
from robocog.agent.analysis.scores import FamilyRow, families, models

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.figure import Figure
    from matplotlib.projections.polar import PolarAxes


#: The capability profile needs this many families (axes) to be a polygon.
CAPABILITY_AXES = 3
CAPABILITY_FILE = "capability.png"


def side_of(angle: float) -> Literal["left", "center", "right"]:
    """How an axis label at `angle` (clockwise from the top) is aligned: away from the circle on the
    sides (a long name centred there would reach back over the axis's point at 100%), centred at the
    top and bottom."""
    across = math.sin(angle)
    return "left" if across > 0.1 else "right" if across < -0.1 else "center"


def axis_label(scores: Sequence[FamilyRow], name: str) -> str:
    """An axis's label: its name and n (the attempts of the model with the most on it); with one model,
    the success rate's 95% interval too."""
    mine = [s for s in scores if s.family == name]
    n = max((s.attempts for s in mine), default=0)
    if len(mine) == 1 and mine[0].attempts and mine[0].success_ci is not None:
        low, high = mine[0].success_ci
        return f"{name.replace('_', ' ')}\n{100 * low:.0f}–{100 * high:.0f}%, n = {n}"
    return f"{name.replace('_', ' ')}\n(n = {n})"


def draw_capability(scores: Sequence[FamilyRow], out: Path, *, group: str = "family") -> str | None:
    """The capability profile: a radar with one axis per family, or per capability tag when the rows
    carry tags (`group="capability"`, `robocog.agent.analysis.scores.capability_scores`): its success
    rate (errored attempts left out; on an infeasible instance the honest failure) and one
    line per model. Returns the file name, or None with fewer than `CAPABILITY_AXES` axes."""
    fig = capability_radar(scores, group=group)
    if fig is None:
        return None
    path = out / CAPABILITY_FILE
    fig.savefig(path)
    return path.name


def capability_radar(scores: Sequence[FamilyRow], *, group: str = "family") -> Figure | None:
    """The figure `draw_capability` saves (None with fewer than `CAPABILITY_AXES` axes)."""
    names = families(scores)
    if len(names) < CAPABILITY_AXES:
        return None
    angles = [2 * math.pi * i / len(names) for i in range(len(names))]
    fig = new_figure(6.4, 5.6)
    ax = cast("PolarAxes", fig.add_subplot(1, 1, 1, projection="polar"))
    ax.set_theta_offset(math.pi / 2)  # the first family at the top, the others clockwise
    ax.set_theta_direction(-1)
    handles: list[Artist] = []
    labels: list[str] = []
    for j, model in enumerate(models(scores)):
        mine = {s.family: s for s in scores if s.model == model}
        values = [mine[f].success if f in mine else math.nan for f in names]
        ring, closed = [*angles, angles[0]], [*values, values[0]]
        colour = TAB10[j % len(TAB10)]
        (line,) = ax.plot(ring, closed, marker="o", color=colour, linewidth=1.8)
        ax.fill(ring, [0.0 if math.isnan(v) else v for v in closed], color=colour, alpha=0.08)
        handles.append(line)
        labels.append(model)
    ax.set_xticks(angles, [axis_label(scores, f) for f in names], fontsize=8)
    ax.tick_params(axis="x", pad=18)  # the names clear of the rim, and of a polygon reaching it
    for label, angle in zip(ax.get_xticklabels(), angles, strict=True):
        label.set_horizontalalignment(side_of(angle))
    ax.set_ylim(0, 1)
    ax.set_yticks([0.25, 0.5, 0.75, 1.0], ["25%", "50%", "75%", "100%"], fontsize=7, color="grey")
    ax.set_rlabel_position(180 / len(names))  # between the first two axes
    ax.grid(alpha=0.4)
    legend_below(fig, handles, labels, "model")
    fig.suptitle(
        f"Capability profile: success per {group} (infeasible: honest failure)\n"
        "errored attempts left out; n = attempts of the model with the most on the axis",
        fontsize=10,
    )
    return fig
