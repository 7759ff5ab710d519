"""`robocog view RESULTS`: browse a study in a web page on loopback (`robocog.agent.view`), or write it
as a static site (`--bundle DIR`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    vw: argparse.ArgumentParser = sub.add_parser(
        "view", help="browse a study in a web page: tables, figures, attempts and their traces"
    )
    vw.add_argument("results", type=Path, help="results file written by robocog eval")
    vw.add_argument("--port", type=int, default=8767, help="port on 127.0.0.1 (default: 8767; 0 picks a free one)")
    vw.add_argument("--title", default=None, help="the report's title")
    vw.add_argument(
        "--bundle",
        type=Path,
        default=None,
        metavar="DIR",
        help="write the viewer as a static site into DIR (no server: open DIR/index.html, or publish DIR)",
    )
    return vw


def main(args: argparse.Namespace) -> int:
    from robocog.agent.view.serve import view_command  # Starlette and the report: only for this command

    return view_command(args)
