"""Markdown for the report: a table, a cell's text made safe (no HTML, no link), a share as a percentage."""

from __future__ import annotations

import math


def pct(x: float | None) -> str:
    """A share as a percentage with one decimal ("n/a" for none or NaN)."""
    return "n/a" if x is None or math.isnan(x) else f"{100 * x:.1f}%"


#: What a label (a model's, a task's: anyone's words) may not carry into Markdown as it is: HTML (a
#: `<script>`, an `<img onerror>`), a link (`[x](javascript:...)`), a table's column bar, a line break.
_SAFE = str.maketrans(
    {"&": "&amp;", "<": "&lt;", ">": "&gt;", "[": "\\[", "]": "\\]", "|": "\\|", "\n": " ", "\r": " "}
)


def cell(text: str) -> str:
    """Text made safe for a markdown table cell or a line of the report: no HTML, no link, no column
    bar and no line break gets through (any Markdown renderer shows the words as they were written)."""
    return text.translate(_SAFE)


def code(text: str) -> str:
    """Text made safe inside a code span in a table cell (where HTML is shown, not run): no backtick,
    column bar or line break."""
    return text.replace("`", "'").replace("|", "\\|").replace("\n", " ").replace("\r", " ")


def md_table(header: list[str], lines: list[list[str]]) -> str:
    """A markdown table: a header row, its rule, a row per line."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)
