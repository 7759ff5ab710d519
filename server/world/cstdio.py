"""Keeping C code's stdout off Python's stdout (an MCP stdio stream, or a JSON report).

PyBullet prints from C: a banner when it is imported, `argv[0]=` when a client connects. This
module imports nothing of PyBullet, so callers can guard the import itself.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator


def flush_c_stdio() -> None:
    """Flush the C runtime's stdio buffers, so text C code printed goes out now, where fd 1 points now:
    the process's own C library on POSIX, the universal C runtime (ucrtbase, which Python and the
    extension modules built for it share) on Windows, where `CDLL(None)` is a TypeError; nothing
    where neither is found."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        runtime = ctypes.CDLL("ucrtbase") if sys.platform == "win32" else ctypes.CDLL(None)
        runtime.fflush(None)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Point fd 1 at stderr for a while. PyBullet's C code prints on stdout (a banner at import,
    `argv[0]=` on connect); stdout may be an MCP stdio stream or a JSON report."""
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        flush_c_stdio()
        os.dup2(saved, 1)
        os.close(saved)


@contextlib.contextmanager
def c_output_discarded(*, stderr: bool = False) -> Iterator[None]:
    """Point fd 1 (and fd 2, with `stderr`) at /dev/null for a while: PyBullet's banner at import
    (`pybullet build time: ...`, on stderr) and its `argv[0]=` on connect (on stdout) say nothing a
    user needs. A Python exception raised meanwhile is printed after, where stderr points again."""
    fds = (1, 2) if stderr else (1,)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in fds]
    null = os.open(os.devnull, os.O_WRONLY)
    for fd in fds:
        os.dup2(null, fd)
    os.close(null)
    try:
        yield
    finally:
        flush_c_stdio()
        for fd, copy in zip(fds, saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)
