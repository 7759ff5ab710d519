"""The fleet servers a study spawns (`robocog eval --isolation fleet`).

A fleet server (`robocog-server --transport http --robots N`) hosts a robot per MCP session in one
process, sharing the embedding model and the Chroma client: about 29 MB per robot instead of about
370 MB per server process. PyBullet holds the GIL while it steps, so one process uses about one
core; a study spreads its workers over a few fleets (by default one per core, and one per 16
workers when that is more: `default_processes`), worker i on fleet i mod P. Each fleet keeps its
memory in its own data directory, where every unit has a namespace of its own. A fleet that dies
is started again on the same port over the same data directory when a worker next connects (its
units resume from the iteration that broke, as with a server process), unless it keeps dying.
"""

from __future__ import annotations

import asyncio
import math
import os
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Self

from robocog.agent.client.connection import default_server_command
from robocog.shared.errors import ServerConnectionError
from robocog.shared.process import PARENT_ENV, free_port, refused, wait_listening

#: How long a fleet may take to listen (its imports and first robot take about 3 s on this machine).
START_TIMEOUT_S = 90.0
#: A fleet that has died this many times within the window is not started again: the study stops
#: with the end of its log (something kills it, or it cannot run), where it would restart without end.
MAX_RESTARTS, RESTART_WINDOW_S = 3, 60.0
#: How long a fleet that refuses connections while it still runs is given to exit before it is killed.
DYING_S = 5.0


def memory_args(server_args: Sequence[str], data_dir: Path) -> list[str]:
    """A spawned server's arguments: its own embedded memory in `data_dir`, unless `server_args` point
    it to a Chroma server (`--memory-url`), where every unit's namespace is its own anyway."""
    memory_url = any(a == "--memory-url" or a.startswith("--memory-url=") for a in server_args)
    return [*server_args] if memory_url else ["--data-dir", str(data_dir), *server_args]


#: The most robots a fleet process serves before the harness spawns more fleets than cores: a fleet runs
#: one robot's call at a time (PyBullet holds the GIL), so with more robots each call waits longer
#: for the others' (64 workers on 2 cores reach more of the ideal on 4 fleets than on 2, for about
#: 0.7 GB more: docs/figures.md, Scale).
ROBOTS_PER_PROCESS = 16


def default_processes(workers: int) -> int:
    """How many fleets `workers` workers get unless told: one per core, and more when that would put
    over `ROBOTS_PER_PROCESS` robots in each."""
    return max(os.cpu_count() or 1, math.ceil(workers / ROBOTS_PER_PROCESS))


class Fleets:
    """`processes` fleet servers for `workers` workers, on loopback, each with its own data directory
    under `memory_dir` (default `work_dir`, which holds their logs); used as an async context manager
    (started on entry, stopped on exit)."""

    def __init__(
        self,
        workers: int,
        work_dir: Path,
        *,
        processes: int | None = None,
        server_command: list[str] | None = None,
        server_args: list[str] | None = None,
        memory_dir: Path | None = None,
    ) -> None:
        self.processes = max(1, min(processes or default_processes(workers), workers))
        #: Robots per fleet: its share of the workers, and one to spare for a session that is closing.
        self.robots = math.ceil(workers / self.processes) + 1
        self.work_dir = work_dir
        self.memory_dir = memory_dir if memory_dir is not None else work_dir
        self.command = list(server_command or default_server_command())
        #: robocog's own server answers each call with one JSON body: no worker asks for progress or logs,
        #: and an event stream per call cost both sides about 1.7 ms of CPU (a server given by its command
        #: may not know the flag).
        self.json_response = server_command is None
        self.server_args = list(server_args or [])
        self.ports = [free_port() for _ in range(self.processes)]
        self._procs: list[subprocess.Popen[bytes] | None] = [None] * self.processes
        self._logs: list[IO[bytes] | None] = [None] * self.processes
        self._restarts: list[list[float]] = [[] for _ in range(self.processes)]  # when each was started again
        self._lock = asyncio.Lock()

    @property
    def urls(self) -> list[str]:
        return [f"http://127.0.0.1:{port}/mcp" for port in self.ports]

    def _args(self, index: int) -> list[str]:
        return [
            *("--transport", "http", "--host", "127.0.0.1", "--port", str(self.ports[index])),
            *("--profile", "eval", "--robots", str(self.robots), "--max-sessions", str(self.robots + 4)),
            *memory_args(self.server_args, self.memory_dir / f"fleet-{index}"),
            *(["--json-response"] if self.json_response else []),
        ]

    def _log_path(self, index: int) -> Path:
        return self.work_dir / f"fleet-{index}.log"

    def _start(self, index: int) -> None:
        self.work_dir.mkdir(parents=True, exist_ok=True)
        log = self._logs[index] = self._log_path(index).open("ab")
        env = {**os.environ, "ANONYMIZED_TELEMETRY": "False", PARENT_ENV: str(os.getpid())}
        self._procs[index] = subprocess.Popen([*self.command, *self._args(index)], stdout=log, stderr=log, env=env)

    async def _wait_listening(self, index: int) -> None:
        proc = self._procs[index]
        assert proc is not None
        problem = await asyncio.to_thread(wait_listening, self.ports[index], proc, START_TIMEOUT_S)
        if problem is not None:
            raise ServerConnectionError(self._failure(index, problem))

    def _failure(self, index: int, what: str) -> str:
        lines = self._log_path(index).read_text(encoding="utf-8", errors="replace").splitlines()
        tail = "\n".join(lines[-15:])
        return f"the fleet server {index} ({self.urls[index]}) {what}; the end of its log:\n{tail}"

    async def ensure(self, worker: int) -> None:
        """Start worker `worker`'s fleet again if it has died (same port, same data directory), unless
        it has died `MAX_RESTARTS` times within `RESTART_WINDOW_S` already (`ServerConnectionError`)."""
        index = worker % self.processes
        async with self._lock:
            proc = self._procs[index]
            if proc is not None and proc.poll() is None:
                if not await asyncio.to_thread(refused, self.ports[index]):
                    return
                # running but refusing connections: killed and not yet gone (a worker that saw it go can
                # get here first), or hung: it is given a moment to exit, then killed
                try:
                    await asyncio.to_thread(proc.wait, DYING_S)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    await asyncio.to_thread(proc.wait)
            now = time.monotonic()
            recent = self._restarts[index] = [t for t in self._restarts[index] if now - t < RESTART_WINDOW_S]
            if len(recent) >= MAX_RESTARTS:
                died = f"died {len(recent) + 1} times within {RESTART_WINDOW_S:g} s and is not started again"
                raise ServerConnectionError(self._failure(index, died))
            recent.append(now)
            self._close_log(index)
            self._start(index)
            await self._wait_listening(index)

    async def __aenter__(self) -> Self:
        try:
            for index in range(self.processes):
                self._start(index)
            await asyncio.gather(*(self._wait_listening(i) for i in range(self.processes)))
        except BaseException:
            self.stop()
            raise
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await asyncio.to_thread(self.stop)

    def stop(self) -> None:
        for proc in self._procs:
            if proc is not None and proc.poll() is None:
                proc.terminate()
        for index, proc in enumerate(self._procs):
            if proc is not None:
                try:
                    proc.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            self._close_log(index)

    def _close_log(self, index: int) -> None:
        log = self._logs[index]
        if log is not None:
            log.close()
            self._logs[index] = None
