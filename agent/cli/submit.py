"""`robocog submit prepare RESULTS --out submission.json` and `robocog submit validate FILE`: a study
packed for a leaderboard elsewhere, and checked (`robocog.agent.analysis.submission`). Reads results
and submissions only: it imports neither the MCP SDK nor LiteLLM. `robocog submit verify` is parsed
here and run by `robocog.agent.cli.submit_verify` (it runs a robot server)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    sm: argparse.ArgumentParser = sub.add_parser(
        "submit", help="pack a study into a submission for a leaderboard, or validate one"
    )
    actions = sm.add_subparsers(dest="action", required=True)
    prep = actions.add_parser("prepare", help="write a submission from a results file")
    prep.add_argument("results", type=Path, help="results file written by robocog eval (its traces beside it)")
    prep.add_argument("--out", type=Path, required=True, help="the submission file to write, e.g. submission.json")
    val = actions.add_parser("validate", help="check a submission: its digests, its coverage, its trials")
    val.add_argument("submission", type=Path, help="a file written by robocog submit prepare")
    ver = actions.add_parser(
        "verify", help="replay every attempt's tool calls in the physics and check its recorded verdict"
    )
    ver.add_argument("submission", type=Path, help="a file written by robocog submit prepare (it carries the traces)")
    ver.add_argument("--out", type=Path, default=None, help="the replay record (default: SUBMISSION.replay.json)")
    ver.add_argument("--server-cmd", default=None, help="the robot server's command line (default: robocog-server)")
    ver.set_defaults(command_module="submit_verify")  # it runs a server: robocog.agent.cli.submit_verify
    for parser in (prep, val, ver):
        parser.add_argument(
            "--suite-dir",
            type=Path,
            action="append",
            default=[],
            help="a suite directory (suite.yaml and its splits) the rows may name besides the shipped suites; "
            "repeatable",
        )
    return sm


def _fail(path: Path, exc: BaseException) -> int:
    problem = " ".join(str(exc).split())
    print(f"robocog: {problem if problem.startswith(str(path)) else f'{path}: {problem}'}", file=sys.stderr)
    return 2


def main(args: argparse.Namespace) -> int:
    """Run `robocog submit prepare|validate`; returns the exit code."""
    from pydantic import ValidationError

    from robocog.agent.analysis.submission import prepare, validate
    from robocog.agent.analysis.untrusted import SUBMISSION_BYTES

    if args.action == "prepare":
        try:
            data = prepare(args.results, args.suite_dir)
        except (OSError, ValueError, ValidationError, RecursionError) as exc:
            return _fail(args.results, exc)
        text = json.dumps(data, indent=1) + "\n"
        if len(text.encode("utf-8")) > SUBMISSION_BYTES:
            size = len(text.encode("utf-8"))
            return _fail(
                args.results, ValueError(f"its submission would be {size:,} bytes, more than {SUBMISSION_BYTES:,}")
            )
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, encoding="utf-8")
        problems, _ = validate(data, args.suite_dir)
        print(f"submission: {args.out} ({len(data['rows'])} rows, {len(data['models'])} models)")
        for line in problems:
            print(f"robocog: warning: {args.out}: {line}", file=sys.stderr)
        return 0
    return validate_command(args.submission, args.suite_dir)


def validate_command(path: Path, local: list[Path]) -> int:
    """`robocog submit validate FILE`: exit 0 and a verdict when valid, 2 and the problems when not (a
    file the bounds refuse: one line)."""
    from robocog.agent.analysis.provenance import verify
    from robocog.agent.analysis.submission import validate
    from robocog.agent.analysis.untrusted import read_json

    try:
        data = read_json(path)
    except (OSError, ValueError) as exc:
        return _fail(path, exc)
    problems, rows = validate(data, local)
    if problems:
        print(f"robocog: {path}: not a valid submission: {problems[0]}", file=sys.stderr)
        for line in problems[1:]:
            print(f"robocog: {path}: also: {line}", file=sys.stderr)
        return 2
    traced = {id(r): t is not None or r.outcome == "not_run" for r, t in zip(rows, data["traces"], strict=True)}
    verification = verify(rows, lambda r: traced[id(r)])
    covers = f"{data['suite']}/{data['split']}" if data.get("suite") else ", ".join(data.get("tasks") or [])
    shipped = "ran on what robocog ships (to verify it, replay it: robocog submit verify)"
    mark = shipped if verification.verified else "not verified: " + "; ".join(verification.problems)
    print(f"{path}: valid ({len(rows)} rows, {data['trials_per_instance']} trials per instance, {covers}); {mark}")
    return 0
