"""A study's results file (JSONL, one `AttemptRow` a line): reading it, mending a torn last line,
and filling in the error taxonomy of rows written before it. Imports neither MCP nor LiteLLM, so
`robocog report` and `robocog view` read results without the client's start-up cost.
"""

from __future__ import annotations

import sys
from pathlib import Path

from pydantic import ValidationError

from robocog.agent.analysis.taxonomy import annotate
from robocog.shared.config_files import validation_problems
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import AttemptRow
from robocog.shared.trace import read_trace


def read_rows(path: Path) -> list[AttemptRow]:
    """The attempts of a results file, in order (none when it does not exist)."""
    if not path.exists():
        return []
    lines = [line for line in path.read_text(encoding="utf-8", errors="replace").splitlines() if line.strip()]
    rows = []
    for number, line in enumerate(lines, 1):
        try:
            rows.append(AttemptRow.model_validate_json(line))
        except ValidationError as exc:
            if number == len(lines) and _torn(line, exc):  # a crash while the last row was written: it reruns
                print(f"robocog: {path}: dropping a torn last line ({number})", file=sys.stderr)
                break
            if not rows:
                raise ConfigError(f"{path}: not a results file of robocog eval (line 1: {_reason(exc)})") from None
            raise ConfigError(f"{path}: line {number} is not a result row ({_reason(exc)})") from None
    return rows


def _torn(line: str, exc: ValidationError) -> bool:
    """Whether `line` is a row cut short: JSON that begins as a row's and ends before it closes."""
    errors = exc.errors()
    return (
        line.lstrip().startswith('{"model"')
        and len(errors) == 1
        and errors[0]["type"] == "json_invalid"
        and "EOF" in str(errors[0]["msg"])
    )


def _reason(exc: ValidationError) -> str:
    """Why a line is not a row, in one line: not JSON (where), not an object, or the fields it lacks."""
    errors = exc.errors()
    if errors and errors[0]["type"] == "json_invalid":
        return f"not JSON: {errors[0]['msg'].removeprefix('Invalid JSON: ')}"
    if errors and errors[0]["type"] == "model_type":
        return "a JSON value that is not an object"
    return validation_problems(exc)


def mend_torn_tail(path: Path) -> None:
    """Before a resumed run appends to `path`: cut a torn last line (the row `read_rows` dropped,
    whose attempt reruns), and end a whole last row that lost its newline, so every appended row
    starts a line of its own."""
    if not path.exists():
        return
    data = path.read_bytes()
    body = data.rstrip()
    start = body.rfind(b"\n") + 1
    try:
        AttemptRow.model_validate_json(body[start:])
    except ValueError:
        with path.open("r+b") as f:
            f.truncate(start)
        return
    if not data.endswith(b"\n"):
        with path.open("ab") as f:
            f.write(b"\n")


def load_rows(path: Path) -> list[AttemptRow]:
    """The attempts of a results file written by `robocog eval` (rows written before the error
    taxonomy get it from their traces, where those are at hand: `with_taxonomy`)."""

    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results file")
    return with_taxonomy(read_rows(path), path.parent)


def with_taxonomy(rows: list[AttemptRow], base: Path) -> list[AttemptRow]:
    """Rows without the taxonomy's counts get them (and their robot actions) from their trace file,
    relative to `base`, when it exists and reads; errored attempts and other rows stay as they are."""
    out = []
    for r in rows:
        trace = base / r.trace if r.trace else None
        if r.errors or r.outcome == "error" or trace is None or not trace.is_file():
            out.append(r)
            continue
        try:
            events = read_trace(trace)
        except (OSError, ValueError):  # a torn or foreign trace: the row keeps what it has
            out.append(r)
            continue
        out.append(annotate(r, events))
    return out
