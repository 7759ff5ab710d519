"""`robocog leaderboard RESULTS... --out DIR`: studies side by side, one row per model and protocol,
as a static page (`robocog.agent.view.leaderboard_page`). Reads results files and submissions only:
it imports neither the MCP SDK nor LiteLLM."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    lb: argparse.ArgumentParser = sub.add_parser(
        "leaderboard", help="studies side by side: a static, sortable page with success against cost"
    )
    lb.add_argument(
        "results", type=Path, nargs="+", help="results files (robocog eval) or submissions (robocog submit prepare)"
    )
    lb.add_argument("--out", type=Path, required=True, help="directory for index.html, leaderboard.json/.md, the plot")
    lb.add_argument(
        "--suite-dir",
        type=Path,
        action="append",
        default=[],
        help="a suite directory (suite.yaml, its splits) submissions may name besides the shipped suites; repeatable",
    )
    return lb


def main(args: argparse.Namespace) -> int:
    """Run `robocog leaderboard`; returns the exit code."""
    from pydantic import ValidationError

    from robocog.agent.analysis.submission import load_study
    from robocog.agent.view.leaderboard_page import write_leaderboard

    studies = []
    for path in args.results:
        try:
            if not path.exists():
                raise FileNotFoundError(f"{path}: no such file")
            studies.append(load_study(path, args.suite_dir))
        except (OSError, ValueError, ValidationError, RecursionError, MemoryError) as exc:
            problem = " ".join(str(exc).split())
            print(f"robocog: {problem if problem.startswith(str(path)) else f'{path}: {problem}'}", file=sys.stderr)
            return 2
    try:
        written = write_leaderboard(studies, args.out)
    except ValueError as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    for line in written.board.warnings:
        print(f"robocog: warning: {line}", file=sys.stderr)
    entries = written.board.entries
    verified = sum(e.verification.verified for e in entries)
    from_ = f"{len(studies)} {'study' if len(studies) == 1 else 'studies'}"
    print(f"leaderboard: {written.index} ({len(entries)} entries from {from_}, {verified} verified)")
    return 0
