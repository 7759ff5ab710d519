"""robocog-server where POSIX-only things are missing, as on Windows and macOS (the MCP Bundle claims
both): started with each thing it uses only on some systems taken away from its process first
(shared/process.py lists them), it starts, lists its tools, moves the robot, ends a task and exits
cleanly when its input ends.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.e2e.test_packaging import rpc
from tests.helpers import APP_TOOLS, ROBOT_TOOLS

#: Each POSIX-only thing robocog-server uses at start or in a tool call (shared/process.py lists them),
#: taken away in the server's process before it starts, as on a system without it.
ABSENT = {
    # glibc, as on Windows: no libc by name, `CDLL(None)` refused, no C library found
    "glibc (Windows)": """
import ctypes, ctypes.util
real = ctypes.CDLL
def cdll(name, *args, **kwargs):
    if name is None:
        raise TypeError("LoadLibrary() argument 1 must be str, not None")
    if "libc" in str(name) or name == "ucrtbase":
        raise FileNotFoundError(f"Could not find module {name!r}")
    return real(name, *args, **kwargs)
ctypes.CDLL = cdll
ctypes.util.find_library = lambda name: None
""",
    # a C library without glibc's extensions, as macOS's libSystem: no mallopt, prctl, malloc_trim
    "glibc (macOS)": """
import ctypes, ctypes.util
real = ctypes.CDLL
class System:
    def __init__(self, lib):
        self._lib = lib
    def __getattr__(self, name):
        if name in ("mallopt", "prctl", "malloc_trim"):
            raise AttributeError(name)
        return getattr(self._lib, name)
def cdll(name, *args, **kwargs):
    if name is not None and "libc.so" in str(name):
        raise OSError(f"dlopen({name}): image not found")
    lib = real(name, *args, **kwargs)
    return System(lib) if name is None or "libc" in str(name) else lib
ctypes.CDLL = cdll
ctypes.util.find_library = lambda name: "libc.so.6" if name == "c" else None
""",
    "uvloop": "import sys\nsys.modules['uvloop'] = None\n",
    # fcntl, as on Windows (robocog's stdio tells it by the platform; the MCP SDK, imported first, too)
    "fcntl": """
import sys, types
import robocog.server.transport.stdio as stdio
stdio.sys = types.SimpleNamespace(**{**vars(sys), "platform": "win32"})
sys.modules["fcntl"] = None
""",
    # the signals Windows lacks, and an event loop that cannot take one
    "signals": """
import asyncio, signal
for name in "SIGHUP SIGQUIT SIGKILL SIGUSR1 SIGUSR2 SIGPIPE SIGALRM SIGCHLD SIGCONT SIGSTOP".split():
    delattr(signal, name)
def refused(*args, **kwargs):
    raise NotImplementedError
asyncio.AbstractEventLoop.add_signal_handler = refused
asyncio.unix_events._UnixSelectorEventLoop.add_signal_handler = refused
""",
    "fork": """
import multiprocessing, os
del os.fork, os.forkpty
multiprocessing.set_start_method("spawn", force=True)
""",
    # /dev/shm, to every file operation of Python's
    "/dev/shm": """
import builtins, os
def hidden(call, at=0):
    def guarded(*args, **kwargs):
        path = args[at] if len(args) > at else kwargs.get("path", kwargs.get("file"))
        if isinstance(path, (str, bytes, os.PathLike)) and os.fsdecode(path).startswith("/dev/shm"):
            raise FileNotFoundError(2, "No such file or directory", os.fsdecode(path))
        return call(*args, **kwargs)
    return guarded
for name in ("stat", "lstat", "open", "scandir", "listdir", "mkdir", "makedirs", "access", "statvfs"):
    setattr(os, name, hidden(getattr(os, name)))
builtins.open = hidden(builtins.open)
""",
}


@pytest.mark.parametrize("absent", list(ABSENT))
def test_the_server_starts_and_acts_without(absent: str, tmp_path: Path) -> None:
    """robocog-server over stdio, with `absent` taken away first: it starts, lists its tools, moves the
    robot and ends a task (a write to episodic memory), and exits cleanly when its input ends."""
    boot = ABSENT[absent] + (
        "\nimport os\nos.environ['ROBOCOG_PARENT_PID'] = str(os.getppid())  # a parent to follow, as a fleet's\n"
        "from robocog.server.cli import main\n"
        f"raise SystemExit(main(['--data-dir', {str(tmp_path / 'memory')!r}]))\n"
    )
    env = {**os.environ, "ANONYMIZED_TELEMETRY": "False"}
    env.pop("MALLOC_ARENA_MAX", None)
    log = tmp_path / "server.log"
    with log.open("wb") as errors:
        proc = subprocess.Popen(
            [sys.executable, "-c", boot], env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=errors
        )
        try:
            hello = {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "t", "version": "0"}}
            init = rpc(proc, {"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": hello}, timeout_s=120)
            rpc(proc, {"jsonrpc": "2.0", "method": "notifications/initialized"}, timeout_s=5)
            tools = rpc(proc, {"jsonrpc": "2.0", "id": 2, "method": "tools/list"}, timeout_s=60)
            calls = [
                {"name": "move_to", "arguments": {"location": "Kitchen Door"}},
                {"name": "end_task", "arguments": {"status": "failure", "description": "t", "summary": "s"}},
            ]
            results = [
                rpc(proc, {"jsonrpc": "2.0", "id": 3 + i, "method": "tools/call", "params": c}, timeout_s=60)
                for i, c in enumerate(calls)
            ]
            assert proc.stdin is not None
            proc.stdin.close()
            code = proc.wait(timeout=60)
        except AssertionError:
            proc.kill()
            raise AssertionError(f"without {absent}:\n{log.read_text(errors='replace')[-3000:]}") from None
    said = log.read_text(errors="replace")
    assert init is not None and "Physics: pybullet" in init["result"]["instructions"]
    assert tools is not None and {t["name"] for t in tools["result"]["tools"]} == ROBOT_TOOLS | APP_TOOLS
    for result in results:
        assert result is not None and not result["result"]["isError"], result
    assert code == 0 and "Traceback" not in said, said
