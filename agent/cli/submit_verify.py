"""`robocog submit verify SUBMISSION`: every attempt of a submission (or of a results file, its traces
beside it) replayed in the physics from its
own trace (`robocog.agent.harness.replay`), its verdict recomputed; every attempt whose recorded
verdict differs is named, and the exit code is 1 when any does (or when an attempt has no trace to
replay). The record of the replay is written beside the submission (`NAME.replay.json`), where
`robocog leaderboard` reads it. Its parser is `robocog submit`'s (`robocog.agent.cli.submit`): this
module is apart because it runs a robot server, which reading results never does."""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any


def _traces(texts: list[Any], where: Path) -> list[Any]:
    """Each row's trace events from the submission's trace texts (None where it carries none)."""
    from robocog.agent.analysis.untrusted import Refused, json_shape
    from robocog.shared.trace import parse_event

    out: list[Any] = []
    for number, text in enumerate(texts, 1):
        if text is None:
            out.append(None)
            continue
        events = []
        for line in text.splitlines():
            if not line.strip():
                continue
            containers, depth = json_shape(line.encode("utf-8", "surrogatepass"))
            if depth > 64 or containers > 100_000:
                raise Refused(f"{where}: the trace of row {number} nests too deep or holds too much")
            try:
                events.append(parse_event(line))
            except ValueError:
                raise Refused(f"{where}: the trace of row {number} holds a line that is no trace event") from None
        out.append(events)
    return out


def _load(path: Path, local: list[Path]) -> tuple[tuple[Any, ...], list[Any]]:
    """The rows of a submission (validated) or of a results file, and each row's trace events (from the
    submission's trace texts, or the files beside the results file), within the reader's bounds."""
    from robocog.agent.analysis.untrusted import TRACE_BYTES, read_bounded

    if path.suffix == ".jsonl":
        from robocog.agent.analysis.leaderboard import results_study

        study = results_study(path)
        base = path.resolve().parent
        texts = [
            read_bounded(base / str(r.trace), TRACE_BYTES, "trace").decode("utf-8", "replace")
            if t and r.trace
            else None
            for r, t in zip(study.rows, study.traced, strict=True)
        ]
        return study.rows, _traces(texts, path)
    from robocog.agent.analysis.submission import read_submission

    submission = read_submission(path, local)
    carried = submission.data.get("trace_texts")
    if carried is None:
        raise ValueError(f"{path}: carries no traces to replay (prepared by a robocog before submit verify)")
    return submission.rows, _traces(carried, path)


def _splits_root(rows: Sequence[Any], local: list[Path]) -> Path | None:
    """The cache root of the fresh split the rows ran on (regenerated from its seed when missing), for
    the replay's server (`--splits`); None when they ran on a shipped split."""
    from robocog.agent.analysis.untrusted import split_directory
    from robocog.shared.suite import seeded_root

    fresh = {(p.suite, p.split, p.split_seed) for r in rows if (p := r.provenance) and p.split_seed is not None}
    if not fresh:
        return None
    if len(fresh) > 1:
        raise ValueError("the rows are of more than one fresh split: verify one at a time")
    suite, split, seed = next(iter(fresh))
    directory = split_directory(suite, f"{split}@{seed}", local)
    return seeded_root(str(directory), str(split), int(seed))


def _shown(value: Any) -> str:
    return str(value) if not isinstance(value, dict) else ", ".join(f"{k} {v}" for k, v in value.items()) or "none"


def main(args: argparse.Namespace) -> int:
    """Run `robocog submit verify`; returns the exit code (0: every attempt replayed to its verdict)."""
    from robocog.agent.analysis.replay_record import record_path, write_record
    from robocog.agent.client.connection import ServerSpec
    from robocog.agent.harness.fleets import memory_args
    from robocog.agent.harness.replay import replay
    from robocog.shared import __version__

    path: Path = args.submission
    try:
        rows, traces = _load(path, args.suite_dir)
        splits = _splits_root(rows, args.suite_dir)
    except (OSError, ValueError) as exc:
        problem = " ".join(str(exc).split())
        print(f"robocog: {problem if problem.startswith(str(path)) else f'{path}: {problem}'}", file=sys.stderr)
        return 2
    import tempfile

    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="robocog-verify-") as scratch:
        server_args = [] if splits is None else ["--splits", str(splits)]
        spec = ServerSpec(
            extra_args=["--profile", "eval", *memory_args(server_args, Path(scratch) / "memory")], lean=True
        )
        if args.server_cmd:
            import shlex

            spec = ServerSpec(command=shlex.split(args.server_cmd), extra_args=spec.extra_args)
        results = asyncio.run(replay(rows, traces, spec))
    seconds = time.perf_counter() - started
    status = {"matches": "matches", "differs": "differs"}
    entries = []
    for r in results:
        kind = status.get(r.status) or ("missing" if r.why == "no trace" else "skipped")
        differs = {k: {"recorded": a, "replayed": b} for k, (a, b) in r.differs.items()}
        entries.append({"row": r.number, "status": kind, "differs": differs, "seconds": round(r.seconds, 4)})
    out = args.out or record_path(path)
    write_record(path, out, entries, {"robocog_version": __version__, "seconds": round(seconds, 2)})
    bad = [r for r in results if r.status == "differs"]
    missing = [r for r in results if r.status == "not replayed" and r.why == "no trace"]
    for r in bad:
        what = "; ".join(f"{k} recorded {_shown(a)}, replayed {_shown(b)}" for k, (a, b) in r.differs.items())
        print(f"robocog: {path}: {r.name} differs: {what}", file=sys.stderr)
    for r in missing:
        print(f"robocog: {path}: {r.name} has no trace: it cannot be replayed", file=sys.stderr)
    replayed = sum(r.status != "not replayed" for r in results)
    verdict = "every verdict as recorded" if not bad else f"{len(bad)} verdicts differ"
    print(f"{path}: replayed {replayed} of {len(results)} attempts in {seconds:.1f} s: {verdict}; record {out}")
    return 1 if bad or missing else 0
