"""`robocog report RESULTS --out DIR`: the tables, figures and CSV of a study. Reads the results file
only: it imports neither the MCP SDK nor LiteLLM."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    rep: argparse.ArgumentParser = sub.add_parser("report", help="tables, figures and a CSV from a results file")
    rep.add_argument("results", type=Path, help="results file written by robocog eval")
    rep.add_argument("--out", type=Path, required=True, help="directory for report.md, the figures and the CSV")
    rep.add_argument("--title", default=None, help="the report's title")
    rep.add_argument(
        "--csv",
        choices=("ours", "upstream"),
        default="ours",
        help="results.csv: our values (default) or the published encoding (0/1, tasks 1/2, trials from 1)",
    )
    return rep


def main(args: argparse.Namespace) -> int:
    """Run `robocog report RESULTS`; returns the exit code."""
    from pydantic import ValidationError

    from robocog.agent.analysis.provenance import disagreements
    from robocog.agent.analysis.report import render
    from robocog.agent.analysis.results_file import load_rows

    try:
        rows = load_rows(args.results)
        for line in disagreements(rows):
            print(f"robocog: warning: {args.results}: {line}", file=sys.stderr)
        path = render(
            rows, args.out, title=args.title or f"robocog evaluation: {args.results.name}", csv_format=args.csv
        )
    except (FileNotFoundError, ValueError, ValidationError) as exc:
        problem = " ".join(str(exc).split())  # one line
        named = problem.startswith(f"{args.results}: ")  # read_rows' errors name the file already
        print(f"robocog: {problem if named else f'{args.results}: {problem}'}", file=sys.stderr)
        return 2
    print(f"report: {path}")
    return 0
