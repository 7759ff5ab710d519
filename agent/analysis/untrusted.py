"""Reading files a stranger wrote (a submission, the rows and traces it names) without letting them
hurt the reader: every bound is checked before the work it bounds.

- A file is opened once and its kind and size read from the open descriptor (`os.fstat`): anything
  but a regular file (a symlink to /dev/zero, a FIFO, a device) and anything larger than its bound is
  refused before a byte is read; then at most the bound is read (a file that grows meanwhile is
  refused too).
- JSON's nesting and size are measured without recursion (`json_shape`: strings removed, brackets counted)
  before it is parsed, so 100,000 nested lists are refused in one line, not a RecursionError.
- Suites and splits resolve only to a shipped suite (`assets/suites/NAME`) or to a suite directory
  given on the verifier's own command line (`resolve_suite`): a name, never a path from the file.

Every refusal is a `Refused` (a ValueError) whose message is one line.
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robocog.shared.errors import ConfigError

#: A submission's size: its rows (about 2 kB each) and its traces (`robocog.agent.analysis.submission`).
SUBMISSION_BYTES = 64 << 20
#: A results file's size, and one trace file's (a 400-attempt study's rows are about 1 MB).
RESULTS_BYTES = 64 << 20
TRACE_BYTES = 8 << 20
#: JSON nested deeper than this is refused (a submission is about 8 deep; a trace's tool arguments more).
JSON_DEPTH = 64
#: JSON with more objects and arrays than this is refused before it is parsed (each costs memory; a
#: submission holds about 12 per row, its traces are texts).
JSON_CONTAINERS = 1_000_000
#: A split's name: letters, digits, '_' and '-' (never a path).
SPLIT_NAME = re.compile(r"[A-Za-z0-9_\-]{1,64}")

_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")


class Refused(ConfigError):
    """A file or a value a stranger wrote that the reader will not take; the message is one line."""


def _kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISDIR, "a directory"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def read_bounded(path: Path, max_bytes: int, what: str = "file", *, content: bool = True) -> bytes:
    """The bytes of the regular file `path`, refused (`Refused`) when it is anything else or larger
    than `max_bytes`: its kind and size are read before its content, and no more than the bound is read
    (`content=False`: only checked, for a reader that takes a path; b"" returned)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise Refused(f"{path}: no such {what}") from None
    except OSError as exc:
        raise Refused(f"{path}: {exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise Refused(f"{path}: {_kind(info.st_mode)}, not a regular file: a {what} is a regular file")
        if info.st_size > max_bytes:
            raise Refused(f"{path}: {info.st_size:,} bytes, more than the {max_bytes:,} a {what} may have")
        if not content:
            return b""
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > max_bytes:
            raise Refused(f"{path}: more than the {max_bytes:,} bytes a {what} may have (it grew while read)")
        return b"".join(chunks)
    finally:
        os.close(fd)


def json_shape(data: bytes, max_depth: int = JSON_DEPTH) -> tuple[int, int]:
    """How many objects and arrays the JSON text `data` holds, and how deep it nests (0 for a scalar;
    counting stops past `max_depth`), without parsing it: strings are removed and the brackets left are
    counted (no recursion, whatever the depth)."""
    brackets = _STRING.sub(b"", data).translate(None, _NOT_BRACKETS)
    containers = brackets.count(b"[") + brackets.count(b"{")
    if containers > JSON_CONTAINERS:
        return containers, 0
    depth = deepest = 0
    for b in brackets:
        depth += 1 if b in (0x5B, 0x7B) else -1
        if depth > deepest:
            deepest = depth
            if deepest > max_depth:
                break
    return containers, deepest


def loads_bounded(data: bytes, where: str, max_depth: int = JSON_DEPTH) -> Any:
    """JSON parsed from `data` once its nesting is known to be within `max_depth` and its objects and
    arrays within `JSON_CONTAINERS`."""
    containers, depth = json_shape(data, max_depth)
    if containers > JSON_CONTAINERS:
        raise Refused(f"{where}: {containers:,} JSON objects and arrays, more than the {JSON_CONTAINERS:,} allowed")
    if depth > max_depth:
        raise Refused(f"{where}: JSON nested more than {max_depth} deep")
    try:
        return json.loads(data)
    except UnicodeDecodeError as exc:
        raise Refused(f"{where}: not UTF-8 ({exc.reason} at byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise Refused(f"{where}: not JSON ({exc.msg}, line {exc.lineno})") from None


def read_json(path: Path, max_bytes: int = SUBMISSION_BYTES, what: str = "submission") -> Any:
    """The JSON value of the file `path`, within its size and nesting bounds."""
    return loads_bounded(read_bounded(path, max_bytes, what), str(path))


def _suite_name(directory: Path) -> str | None:
    """The name a suite directory's manifest gives itself (None when it has no readable manifest)."""
    from robocog.shared.config_files import read_yaml

    try:
        data = read_yaml(directory / "suite.yaml", max_bytes=1 << 20)
    except (OSError, ValueError):
        return None
    name = data.get("name") if isinstance(data, dict) else None
    return name if isinstance(name, str) else None


def suite_directory(suite: object, local: Sequence[Path] = ()) -> Path:
    """The directory of `suite` as a stranger's file names it: a shipped suite's name, or the name (its
    manifest's or its folder's) of a suite directory in `local`, given on the verifier's own command
    line (`--suite-dir`). Never a path."""
    from robocog.shared.suite import SUITE_NAME, SUITES_DIR

    if not isinstance(suite, str) or len(suite) > 64 or not SUITE_NAME.fullmatch(suite):
        raise Refused(
            f"suite {str(suite)[:80]!r} is not a suite's name (a shipped suite, or one given with --suite-dir)"
        )
    given = [d for d in local if suite in (d.name, _suite_name(d))]
    if given:
        return given[0]
    shipped = SUITES_DIR / suite
    if (shipped / "suite.yaml").is_file():
        return shipped
    known = sorted(p.name for p in SUITES_DIR.iterdir() if (p / "suite.yaml").is_file())
    raise Refused(f"suite {suite!r} is neither shipped ({', '.join(known)}) nor given with --suite-dir")


def split_directory(suite: object, split: object, local: Sequence[Path] = ()) -> Path:
    """The directory of `suite` (`suite_directory`) once `split` is known to be the name of one of its
    splits (a split of its manifest, or a JSONL file in it): never a path."""
    directory = suite_directory(suite, local)
    if not isinstance(split, str) or not SPLIT_NAME.fullmatch(split):
        raise Refused(f"split {str(split)[:80]!r} is not a split's name")
    if not (directory / f"{split}.jsonl").is_file():
        from robocog.shared.suite import load_suite

        splits = sorted(load_suite(str(directory)).splits)
        raise Refused(f"suite {suite!r} has no split {split!r} written (its splits: {', '.join(splits)})")
    return directory
