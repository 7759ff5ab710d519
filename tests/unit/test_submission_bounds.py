"""Submissions that cannot hurt the verifier (`robocog.agent.analysis.untrusted`): every hostile file
below is refused by `robocog submit validate`, `robocog submit prepare` and `robocog leaderboard` in
one line on stderr with exit 2, never a traceback; suites and splits resolve only to shipped suites
or a directory given with --suite-dir; a file's kind and size are read before its content."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.analysis.submission import prepare
from robocog.agent.analysis.untrusted import (
    JSON_DEPTH,
    SUBMISSION_BYTES,
    TRACE_BYTES,
    Refused,
    json_shape,
    read_bounded,
)
from robocog.agent.cli.main import main
from robocog.shared.suite import SUITES_DIR
from tests.helpers import DATA


@pytest.fixture(scope="module")
def honest() -> dict[str, Any]:
    """The submission of the committed results file (the paper's tasks; its traces are not at hand)."""
    return prepare(DATA / "results_paper.jsonl")


def write(path: Path, value: Any) -> Path:
    path.write_text(json.dumps(value))
    return path


def _deep(path: Path, honest: dict[str, Any]) -> Path:
    path.write_text(json.dumps({**honest, "summary": "DEEP"}).replace('"DEEP"', "[" * 100_000 + "]" * 100_000))
    return path


def _sparse(path: Path) -> Path:
    with path.open("wb") as f:  # one byte over the bound, written as a hole: no 64 MB on disk
        f.truncate(SUBMISSION_BYTES + 1)
    return path


def _zero(path: Path) -> Path:
    path.symlink_to("/dev/zero")
    return path


#: Each hostile submission: how to make it from the honest one, and the words of its one-line refusal.
HOSTILE: dict[str, tuple[Callable[[Path, dict[str, Any]], Path], str]] = {
    "100,000-deep nesting": (_deep, f"JSON nested more than {JSON_DEPTH} deep"),
    "a dict in models": (
        lambda p, h: write(p, {**h, "models": [{"model": {"name": "alpha"}}]}),
        "models: item 1 must be an object whose model is a string",
    ),
    "a suite that is a path": (
        lambda p, h: write(p, {**h, "suite": "/any/dir", "split": "dev"}),
        "suite '/any/dir' is not a suite's name",
    ),
    "a split that is a path": (
        lambda p, h: write(p, {**h, "suite": "robocog-v1", "split": "../../x"}),
        "split '../../x' is not a split's name",
    ),
    "a suite shipped nowhere": (
        lambda p, h: write(p, {**h, "suite": "elsewhere", "split": "dev"}),
        "suite 'elsewhere' is neither shipped",
    ),
    "a symlink to /dev/zero": (lambda p, h: _zero(p), "a character device, not a regular file"),
    "a file one byte over the bound": (
        lambda p, h: _sparse(p),
        f"{SUBMISSION_BYTES + 1:,} bytes, more than the {SUBMISSION_BYTES:,} a submission may have",
    ),
    "trials as text": (
        lambda p, h: write(p, {**h, "trials_per_instance": "2"}),
        "trials_per_instance must be an integer",
    ),
    "rows as an object": (lambda p, h: write(p, {**h, "rows": {}}), "rows must be a list, not an object"),
}


@pytest.mark.parametrize("name", list(HOSTILE))
@pytest.mark.parametrize("command", ["validate", "leaderboard"])
def test_a_hostile_submission_is_refused_in_one_line(
    name: str, command: str, honest: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    make, words = HOSTILE[name]
    path = make(tmp_path / "submission.json", honest)
    argv = (
        ["submit", "validate", str(path)]
        if command == "validate"
        else ["leaderboard", str(path), "--out", str(tmp_path / "b")]
    )
    started = time.perf_counter()
    assert main(argv) == 2
    said = capsys.readouterr()
    assert said.out == ""
    assert said.err.count("\n") == 1 and said.err.startswith(f"robocog: {path}: "), said.err
    assert words in said.err
    assert time.perf_counter() - started < 10
    assert not (tmp_path / "b").exists()


def test_the_refusals_are_one_line_from_a_real_process_too(honest: dict[str, Any], tmp_path: Path) -> None:
    """A RecursionError or a TypeError would print a traceback from the real command: none does."""
    for name, (make, words) in HOSTILE.items():
        folder = tmp_path / name.replace(" ", "-").replace("/", "")
        folder.mkdir()
        path = make(folder / "submission.json", honest)
        done = subprocess.run(
            [sys.executable, "-m", "robocog.agent.cli", "submit", "validate", str(path)],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 2, (name, done.stderr)
        assert done.stderr.count("\n") == 1 and words in done.stderr and "Traceback" not in done.stderr, (
            name,
            done.stderr,
        )


def test_prepare_refuses_a_results_file_or_trace_that_is_not_a_regular_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    results = _zero(tmp_path / "results.jsonl")
    assert main(["submit", "prepare", str(results), "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a character device, not a regular file: a results file" in err
    rows = [json.loads(line) for line in (DATA / "results_paper.jsonl").read_text().splitlines()]
    rows[0]["trace"] = "t.jsonl"
    study = tmp_path / "study"
    study.mkdir()
    (study / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    _zero(study / "t.jsonl")  # not a regular file: no trace at all (never read)
    assert main(["submit", "prepare", str(study / "results.jsonl"), "--out", str(tmp_path / "s.json")]) == 0
    assert json.loads((tmp_path / "s.json").read_text())["traces"][0] is None
    (study / "t.jsonl").unlink()
    with (study / "t.jsonl").open("wb") as f:
        f.truncate(TRACE_BYTES + 1)
    assert main(["submit", "prepare", str(study / "results.jsonl"), "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"t.jsonl: {TRACE_BYTES + 1:,} bytes, more than the {TRACE_BYTES:,} a trace" in err


def test_a_suite_resolves_to_a_directory_given_on_the_command_line_only(
    honest: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A submission naming `fresh` is refused until the verifier names a directory `fresh` itself;
    then its coverage is checked against that directory's split (these rows are not of it)."""
    fresh = tmp_path / "fresh"
    shutil.copytree(SUITES_DIR / "robocog-v1", fresh)
    path = write(tmp_path / "s.json", {**honest, "suite": "fresh", "split": "dev"})
    assert main(["submit", "validate", str(path)]) == 2
    assert "suite 'fresh' is neither shipped" in capsys.readouterr().err
    assert main(["submit", "validate", str(path), "--suite-dir", str(fresh)]) == 2
    err = capsys.readouterr().err
    assert "alpha covers 0 of the 70 of fresh/dev" in err, err


def test_the_bounds_are_read_before_the_content(tmp_path: Path) -> None:
    exact = tmp_path / "exact"
    exact.write_bytes(b"x" * 100)
    assert read_bounded(exact, 100) == b"x" * 100
    with pytest.raises(Refused, match="101 bytes, more than the 100"):
        exact.write_bytes(b"x" * 101)
        read_bounded(exact, 100)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(Refused, match="a FIFO, not a regular file"):
        read_bounded(fifo, 100)  # opened without blocking, refused without reading
    with pytest.raises(Refused, match="a directory"):
        read_bounded(tmp_path, 100)


def test_json_nesting_is_measured_without_recursion() -> None:
    assert json_shape(b'{"a": [1, {"b": "[[[[{{{{"}], "c": "\\"]]"}') == (3, 3)
    assert json_shape(b"3") == (0, 0)
    containers, depth = json_shape(("[" * 1_000_000 + "]" * 1_000_000).encode())
    assert containers == 1_000_000 and depth == JSON_DEPTH + 1  # counting stops past the bound
