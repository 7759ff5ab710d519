"""The capability radar's axis labels: each clear of its axis's point at 100%, whatever its length."""

from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Any

import pytest

from robocog.agent.analysis.capability_figure import capability_radar, side_of
from robocog.agent.analysis.scores import FamilyRow

CAPABILITIES = [
    "planning",
    "recovery",
    "memory",
    "honesty",
    "referring",
    "long_horizon",
    "partial_observation",
    "containers",
]


def _row(model: str, family: str) -> FamilyRow:
    fields: dict[str, Any] = {f.name: None for f in dataclasses.fields(FamilyRow)}
    counts = {"attempts": 3, "errored": 0, "stopped": 0, "successes": 3, "achieved": 3, "claims": 3, "failures": 0}
    return FamilyRow(
        **{
            **fields,
            **counts,
            "model": model,
            "family": family,
            "success": 1.0,
            "success_ci": (0.44, 1.0),
            "pass_k": {},
            "pass_k_ci": {},
            "errors": {},
        }
    )


@pytest.mark.parametrize("axes", [3, 5, 8])
def test_no_label_covers_its_axis_point_at_the_rim(axes: int) -> None:
    names = CAPABILITIES[:axes] if axes < len(CAPABILITIES) else CAPABILITIES
    fig = capability_radar([_row("planner", name) for name in names], group="capability")
    assert fig is not None
    fig.canvas.draw()
    ax = fig.axes[0]
    for label, angle in zip(ax.get_xticklabels(), ax.get_xticks(), strict=True):
        box = label.get_window_extent().expanded(1.0, 1.0)
        x, y = ax.transData.transform((angle, 1.0))
        assert not box.contains(x, y), f"{label.get_text()!r} covers its point at 100%"


def test_labels_on_the_sides_read_away_from_the_circle() -> None:
    assert side_of(0.0) == side_of(math.pi) == "center"
    assert side_of(math.pi / 2) == "left" and side_of(3 * math.pi / 2) == "right"


@pytest.mark.parametrize("models", [1, 2])
@pytest.mark.parametrize("axes", [3, 8])
def test_no_label_touches_the_polygon_and_each_gives_its_n(axes: int, models: int) -> None:
    """The labels stay clear of the whole polygon (every model at 100%, so it is the rim), and each
    says its n; with one model, its interval too."""
    names = CAPABILITIES[:axes]
    fig = capability_radar([_row(f"m{j}", name) for j in range(models) for name in names], group="capability")
    assert fig is not None
    fig.canvas.draw()
    ax = fig.axes[0]
    boxes = [label.get_window_extent() for label in ax.get_xticklabels()]
    for label in ax.get_xticklabels():
        assert "n = 3" in label.get_text() and ("44–100%" in label.get_text()) == (models == 1)
    corners = [2 * math.pi * i / axes for i in range(axes + 1)]
    for a, b in itertools.pairwise(corners):
        for t in [i / 40 for i in range(41)]:  # points along each edge of the polygon at 100%
            xa, ya = math.sin(a), math.cos(a)
            xb, yb = math.sin(b), math.cos(b)
            x, y = xa + t * (xb - xa), ya + t * (yb - ya)
            point = ax.transData.transform((math.atan2(x, y) % (2 * math.pi), math.hypot(x, y)))
            assert not any(box.contains(*point) for box in boxes)
