"""Markdown for the report: a table, a cell's text made safe, a share as a percentage."""

from __future__ import annotations

import math


def pct(x: float | None) -> str:
    """A share as a percentage with one decimal ("n/a" for none or NaN)."""
    return "n/a" if x is None or math.isnan(x) else f"{100 * x:.1f}%"


def cell(text: str) -> str:
    """Text made safe for a markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def md_table(header: list[str], lines: list[list[str]]) -> str:
    """A markdown table: a header row, its rule, a row per line."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)
