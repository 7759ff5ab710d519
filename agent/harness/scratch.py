"""Where the servers a study starts keep their memory: in RAM where the machine has room for it.

The servers a study spawns itself (a worker's `robocog-server`, its own fleets) keep every unit's
memory namespace in a data directory of the study's. That memory is scratch by construction: each
unit clears its namespace when it starts and drops it when its last iteration is done, the
directory is deleted when the study ends, and `--resume` runs an unfinished unit again from
scratch. ChromaDB writes it durably all the same: every write is SQLite transactions with a
rollback journal and four `fsync`s, whose kernel work is CPU the study pays for nothing. On a
RAM-backed file system they cost none of it (a unit's memory work on either, and what it saves an
attempt: docs/figures.md, "Start-up and the cost of an attempt").

So a study's servers keep their memory under `ROBOCOG_SCRATCH_DIR` (default `/dev/shm`, Linux's RAM
file system) when that directory exists, is writable and has `MIN_FREE_BYTES` free (a container's
default `/dev/shm` of 64 MB does not); else beside the results, in the study's work directory, as
before. A unit's namespace takes about 180 KB there and is gone when the unit ends; a study with
`keep_memory: true` keeps every namespace until its end, so its memory stays on disk.

The directory is named after the study's process (`robocog-study-PID-...`) and removed when the study
ends, however it ends; one left by a study that was killed is removed by the next study to start.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

#: The environment variable naming the RAM-backed directory (empty: none, keep memory on disk).
SCRATCH_ENV = "ROBOCOG_SCRATCH_DIR"
#: Linux's RAM file system, where it exists.
DEFAULT_SCRATCH = Path("/dev/shm")
#: The free space a study needs there: far more than its namespaces take (about 180 KB each, a few
#: hundred at once for hundreds of workers), so that a small RAM file system is left alone.
MIN_FREE_BYTES = 256 * 1024 * 1024
PREFIX = "robocog-study-"
_NAME = re.compile(rf"^{re.escape(PREFIX)}(\d+)-")


def scratch_root() -> Path | None:
    """The RAM-backed directory studies keep their memory in, if there is one with room: `$ROBOCOG_SCRATCH_DIR`
    (an empty value: none), else `/dev/shm` where it exists."""
    given = os.environ.get(SCRATCH_ENV)
    root = DEFAULT_SCRATCH if given is None else Path(given).expanduser() if given.strip() else None
    if root is None or not root.is_dir() or not os.access(root, os.W_OK | os.X_OK):
        return None
    try:
        free = shutil.disk_usage(root).free
    except OSError:
        return None
    return root if free >= MIN_FREE_BYTES else None


@contextlib.contextmanager
def memory_dir(work_dir: Path, *, keep_memory: bool) -> Iterator[Path]:
    """The directory a study's own servers keep their memory in while the study runs: a new one under
    `scratch_root()`, removed when the study ends; else (no RAM file system with room, or `keep_memory`)
    `work_dir`, which the study removes itself when it succeeds."""
    root = None if keep_memory else scratch_root()
    if root is None:
        yield work_dir
        return
    sweep(root)
    path = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{os.getpid()}-", dir=root))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def sweep(root: Path) -> list[Path]:
    """Remove the memory directories under `root` of studies whose process has gone (killed before it
    could remove its own); the ones removed."""
    removed = []
    with contextlib.suppress(OSError):
        for entry in root.iterdir():
            match = _NAME.match(entry.name)
            if match is None or not entry.is_dir() or _alive(int(match.group(1))):
                continue
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _alive(pid: int) -> bool:
    """Whether process `pid` exists (one of another user's counts: it is not ours to judge)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True
