"""MkDocs hook: the figures `make bench` recorded, written into the pages at build time.

`make bench` (`tests/bench/run.py --record`) merges every figure it measured into
`docs/figures.json` (key → value and the day it was measured). A page names a figure as
`[[fig:KEY]]` and gets its value; `<!-- figures:all -->` becomes the table of every recorded figure,
by bench. A key the file does not hold fails the build (`make docs` is strict), so a figure is
written in one place, by the bench, never copied by hand.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

FIGURES = Path(__file__).resolve().parents[1] / "figures.json"
REFERENCE = re.compile(r"\[\[fig:([A-Za-z0-9_\-]+\.[A-Za-z0-9_.\-]+)\]\]")
ALL = "<!-- figures:all -->"


def recorded() -> dict[str, dict[str, Any]]:
    if not FIGURES.exists():
        return {}
    return dict(json.loads(FIGURES.read_text(encoding="utf-8"))["figures"])


def shown(value: Any) -> str:
    """A figure as text: floats without trailing noise, lists and dicts as compact JSON."""
    if isinstance(value, bool) or value is None:
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:g}" if abs(value) < 1e6 else f"{value:.0f}"
    if isinstance(value, (list, dict)):
        return json.dumps(value, separators=(", ", ": "))
    return str(value)


def table(figures: dict[str, dict[str, Any]]) -> str:
    """Every recorded figure, grouped by its bench (the key's first part), each bench's table folded
    (a collapsed `???` block of pymdownx.details: some 600 rows open at once made the page 47,000 px tall)."""
    lines: list[str] = []
    for bench in sorted({key.split(".", 1)[0] for key in figures}):
        keys = sorted(k for k in figures if k.split(".", 1)[0] == bench)
        lines += [f'??? note "`{bench}`: {len(keys)} figures"', ""]
        lines += ["    | figure | value | measured |", "    |---|---|---|"]
        for key in keys:
            entry = figures[key]
            lines.append(f"    | `{key}` | {shown(entry['value'])} | {entry['date']} |")
        lines.append("")
    return "\n".join(lines)


def on_page_markdown(markdown: str, **_: Any) -> str:
    if "[[fig:" not in markdown and ALL not in markdown:
        return markdown
    figures = recorded()

    def value(match: re.Match[str]) -> str:
        key = match.group(1)
        if key not in figures:
            raise KeyError(f"[[fig:{key}]]: docs/figures.json has no such figure (run its bench with --record)")
        return shown(figures[key]["value"])

    return REFERENCE.sub(value, markdown).replace(ALL, table(figures))
