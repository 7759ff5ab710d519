"""Child processes: a server robocog starts never outlives the process that started it."""

from __future__ import annotations

import contextlib
import ctypes
import signal

#: prctl(2)'s PR_SET_PDEATHSIG.
_PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """In a child process (`subprocess.Popen(preexec_fn=...)`): be sent SIGTERM when the parent
    dies, however it dies (Linux; elsewhere nothing), so no fleet process or Chroma server outlives
    the router or the harness that started it."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
