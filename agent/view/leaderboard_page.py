"""`robocog leaderboard RESULTS... --out DIR`: the leaderboard as a static page (one HTML file, its
data inline, sortable; no server, works from file://) beside its JSON, its markdown and the plot of
success against cost (`robocog.agent.analysis.leaderboard`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from robocog.agent.analysis.leaderboard import Board, Study, board, board_json, board_markdown, draw_success_cost
from robocog.shared.web import VIEWER_STATIC

#: Where the template takes the leaderboard's JSON.
DATA_MARK = "/*DATA*/"


def page(data: dict[str, object]) -> str:
    """The leaderboard page with `data` inline (`</` escaped: no text in it can end the script)."""
    template = (VIEWER_STATIC / "leaderboard.html").read_text(encoding="utf-8")
    if DATA_MARK not in template:
        raise ValueError("the leaderboard's page has no place for its data")
    return template.replace(DATA_MARK, json.dumps(data, ensure_ascii=False).replace("</", "<\\/"))


@dataclass(frozen=True)
class Written:
    index: Path
    board: Board


def write_leaderboard(studies: Sequence[Study], out: Path) -> Written:
    """Write index.html, leaderboard.json, leaderboard.md and the plot into `out`."""
    b = board(studies)
    out.mkdir(parents=True, exist_ok=True)
    data = board_json(b)
    draw_success_cost(b, out)
    (out / "leaderboard.json").write_text(json.dumps(data, indent=2), encoding="utf-8")
    (out / "leaderboard.md").write_text(board_markdown(b), encoding="utf-8")
    index = out / "index.html"
    index.write_text(page(data), encoding="utf-8")
    return Written(index, b)
