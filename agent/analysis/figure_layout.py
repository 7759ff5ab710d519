"""What the report's figures share: a figure (Agg canvas), a grid of panels, a legend below the
axes and the palette (matplotlib's tab10, the paper's colours for the memory iterations).

matplotlib is imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

# The paper's palette for the memory iterations (matplotlib's tab10).
TAB10 = [
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


def iteration_colour(i: int) -> str:
    """The colour of memory iteration `i` (the palette, round again after ten)."""
    return TAB10[i % len(TAB10)]


def new_figure(width: float, height: float) -> Figure:
    """A figure of `width` x `height` inches on its own Agg canvas (no pyplot state)."""
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


def panels(fig: Figure, n: int) -> list[Axes]:
    """`n` panels on `fig`, laid out by `_grid`."""
    rows, cols = _grid(n)
    axes = [fig.add_subplot(rows, cols, i + 1) for i in range(n)]
    return axes


def panel_size(n: int, width: float, height: float) -> tuple[float, float]:
    """The size of a figure of `n` panels of `width` x `height` inches, with room for the legend."""
    rows, cols = _grid(n)
    return width * cols, height * rows + 0.9


def legend_below(fig: Figure, handles: Sequence[Artist], labels: Sequence[str], title: str) -> None:
    """A legend under the panels, outside the axes, in as many columns as the figure's width holds
    (at most 6; long names in a narrow figure wrap into rows rather than run off its sides)."""
    longest = max((len(str(label)) for label in labels), default=1)
    fits = int(fig.get_figwidth() * 13 // (longest + 6))  # about 13 characters of 8-point text an inch
    fig.legend(
        list(handles),
        list(labels),
        title=title,
        loc="outside lower center",
        ncols=max(1, min(len(labels), 6, fits)),
        fontsize=8,
        title_fontsize=8,
        frameon=False,
    )
