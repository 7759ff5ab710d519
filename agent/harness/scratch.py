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

The directory (`robocog-study-PID-...`) is the study's while it holds the lock on the file `LOCK` inside
it (`flock` on POSIX, `msvcrt.locking` on Windows), from before the directory takes its name to the
study's end; the lock goes with the process, however it ends. The directory is removed when the study
ends, also on SIGTERM and SIGINT; one left by a study that was killed is removed by the next study to
start, which removes only what no process holds: a study in another PID namespace sharing the same
`/dev/shm` (a container) holds its lock as well as any, so its directory is never taken for dead.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
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
_NAME = re.compile(rf"^(?:\.making-)?{re.escape(PREFIX)}(\d+)-")


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


#: The file inside a study's directory whose lock says the study is alive.
LOCK = ".lock"
#: A directory without a lock file (from a robocog before the lock) is swept when its process has gone
#: and it has not changed for this long: its pid alone may be another PID namespace's.
LEGACY_AGE_S = 24 * 3600.0


@contextlib.contextmanager
def memory_dir(work_dir: Path, *, keep_memory: bool) -> Iterator[Path]:
    """The directory a study's own servers keep their memory in while the study runs: a new one under
    `scratch_root()`, held by its lock and removed when the study ends (SIGTERM and SIGINT included);
    else (no RAM file system with room, or `keep_memory`) `work_dir`, which the study removes itself
    when it succeeds."""
    root = None if keep_memory else scratch_root()
    if root is None:
        yield work_dir
        return
    sweep(root)
    # Made under a name no sweep looks at, locked, then renamed: no moment where it is a study's and unheld.
    making = Path(tempfile.mkdtemp(prefix=f".making-{PREFIX}{os.getpid()}-", dir=root))
    lock = _hold(making / LOCK)
    path = root / making.name.removeprefix(".making-")
    try:
        making.rename(path)
    except OSError:
        _let_go(lock)
        shutil.rmtree(making, ignore_errors=True)
        raise
    try:
        with _signals_end_the_study():
            yield path
    finally:
        _let_go(lock)  # first: Windows removes no file a process has open
        shutil.rmtree(path, ignore_errors=True)


def sweep(root: Path) -> list[Path]:
    """Remove the memory directories under `root` of studies that no process holds (killed before they
    could remove their own); the ones removed."""
    removed = []
    with contextlib.suppress(OSError):
        for entry in root.iterdir():
            match = _NAME.match(entry.name)
            if match is None or not entry.is_dir():
                continue
            if (entry / LOCK).exists():
                lock = _try_hold(entry / LOCK)
                if lock is None:
                    continue  # a live study's, in this PID namespace or another
                _let_go(lock)  # no study takes a name twice: nothing can claim it between these two lines
                shutil.rmtree(entry, ignore_errors=True)
            elif _alive(int(match.group(1))) or time.time() - _mtime(entry) < LEGACY_AGE_S:
                continue
            else:
                shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except OSError:
        return time.time()


def _hold(path: Path) -> int:
    """Create `path` and hold its lock (this process's until `_let_go` or its end)."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    if not _lock(fd):
        os.close(fd)
        raise OSError(f"{path}: locked by another process")
    return fd


def _try_hold(path: Path) -> int | None:
    """The lock of `path` if no process holds it, else None."""
    try:
        fd = os.open(path, os.O_RDWR)
    except OSError:
        return None
    if _lock(fd):
        return fd
    os.close(fd)
    return None


def _lock(fd: int) -> bool:
    """Take the lock of the open file `fd` without waiting; whether it was free."""
    try:
        if sys.platform == "win32":
            import msvcrt

            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        else:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


def _let_go(fd: int) -> None:
    with contextlib.suppress(OSError):
        os.close(fd)  # closing the file lets go of its lock


@contextlib.contextmanager
def _signals_end_the_study() -> Iterator[None]:
    """While inside: SIGTERM ends the study as SIGINT does (an exception that unwinds it), so the
    directory is removed (on the main thread only, where Python runs signal handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def end(signum: int, frame: object) -> None:
        raise SystemExit(128 + signum)

    before = signal.signal(signal.SIGTERM, end)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def _alive(pid: int) -> bool:
    """Whether process `pid` exists (one of another user's counts: it is not ours to judge)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True
