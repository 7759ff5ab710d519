"""Child processes: a server robocog starts never outlives the process that started it; and the other
POSIX-only things a server does at start, each a no-op where it is missing.

What robocog-server does only on some systems, and where it does without (tests/e2e/test_packaging.py
starts it with each taken away): glibc's malloc arena limit (`limit_malloc_arenas`) and its parent-death
signal (`die_with_parent`), Linux only; libc's `malloc_trim` after Chroma closes (server/memory/chroma.py),
where found; uvloop's event loop (server/config.py), where installed; its stdio served from private
duplicates of fds 0 and 1 (server/transport/stdio.py), where fcntl is; the C runtime's stdio flushed after
PyBullet prints (server/world/cstdio.py), the universal C runtime on Windows. It handles no signal but
SIGTERM (which Windows has too) and forks no process; a fleet's router (`--processes`) gives its shared
Chroma server `preexec_fn=die_with_parent` on POSIX only (Windows refuses a preexec_fn). A study's RAM
scratch directory (/dev/shm) is the harness's, used where it exists (agent/harness/scratch.py).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import signal
import socket
import subprocess
import sys
import time

#: prctl(2)'s PR_SET_PDEATHSIG.
_PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """In a child process (`subprocess.Popen(preexec_fn=...)`): be sent SIGTERM when the parent
    dies, however it dies (Linux; elsewhere nothing), so no fleet process or Chroma server outlives
    the router or the harness that started it."""
    if not sys.platform.startswith("linux"):
        return
    with contextlib.suppress(OSError, AttributeError):  # not glibc (musl): nothing
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


#: Set by a parent for a child robocog-server: its pid. The child then ends with it (`follow_parent`).
PARENT_ENV = "ROBOCOG_PARENT_PID"


def follow_parent() -> None:
    """In a robocog-server started with `PARENT_ENV` set: be sent SIGTERM when that parent dies, and
    end at once if it died already (the server arms this itself, at start, instead of a `preexec_fn`,
    which is unsafe when the parent has threads)."""
    import os

    expected = os.environ.get(PARENT_ENV)
    if not expected:
        return
    die_with_parent()
    if str(os.getppid()) != expected:  # the parent died before the signal was armed
        os._exit(0)


#: mallopt(3)'s M_ARENA_MAX, and the arenas a server keeps (glibc's default is 8 per core).
_M_ARENA_MAX = -8
SERVER_ARENAS = 2


def limit_malloc_arenas(arenas: int = SERVER_ARENAS) -> None:
    """Keep glibc's malloc to `arenas` arenas in this process (Linux with glibc; elsewhere nothing),
    unless `MALLOC_ARENA_MAX` says otherwise. A server answers on many worker threads, and with an
    arena per thread the memory that Chroma and the physics free per episode stays scattered: a
    soak of memory-using episodes grew about 4 MB per 100 episodes, and 0.1 with two arenas. Call it
    first thing, before threads start."""
    import os

    if os.environ.get("MALLOC_ARENA_MAX") or not sys.platform.startswith("linux"):
        return
    with contextlib.suppress(OSError, AttributeError):  # not glibc (musl): nothing
        ctypes.CDLL("libc.so.6").mallopt(_M_ARENA_MAX, arenas)


def free_port() -> int:
    """A TCP port free on loopback right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def probe_bind(host: str, port: int) -> tuple[int, str | None]:
    """Whether a server could listen on `host:port` now: (the port, a free one for 0; None), or (`port`,
    why not: in use, or not this machine's address), from a probe socket bound and closed at once."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as exc:
            return port, exc.strerror or str(exc)
        return int(probe.getsockname()[1]), None


def refused(port: int) -> bool:
    """Whether nothing listens on loopback `port` (a connection refused; one that only waits, as when
    the listener's backlog is full, is a listener)."""
    with socket.socket() as s:
        s.settimeout(2.0)
        return s.connect_ex(("127.0.0.1", port)) == errno.ECONNREFUSED


def wait_listening(port: int, proc: subprocess.Popen[bytes], timeout_s: float) -> str | None:
    """Wait until `proc` listens on loopback `port`: None once it does, else why it never will
    ("exited with status N", "did not listen within T s")."""
    deadline = time.monotonic() + timeout_s
    while True:
        if proc.poll() is not None:
            return f"exited with status {proc.returncode}"
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return None
        if time.monotonic() > deadline:
            return f"did not listen within {timeout_s:g} s"
        time.sleep(0.1)
