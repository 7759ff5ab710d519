"""The router's fleet processes (`robocog-server --robots N --processes P`): which flags they get, how
the robots are shared out, starting them (and the shared memory, `chroma run`) on loopback ports,
starting a dead one again on its port, and serving the router until SIGTERM.
"""

from __future__ import annotations

import os
import secrets
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from robocog.server.config import DRIVER_SECRET_ENV, event_loop_options
from robocog.server.robots.handles import DriverIds
from robocog.server.routing.router import Router, Upstream
from robocog.shared.errors import ConfigError
from robocog.shared.process import PARENT_ENV, die_with_parent, free_port, wait_listening
from robocog.shared.web import SERVER_KEEP_ALIVE_S

#: Flags of the public server that its fleet processes get in another form (or not at all), and
#: whether each takes a value.
OWN_FLAGS = {
    "--transport": True,
    "--host": True,
    "--port": True,
    "--processes": True,
    "--robots": True,
    "--max-sessions": True,
    "--auth-token": True,
    "--data-dir": True,
    "--memory-url": True,
}


START_TIMEOUT_S = 90.0


def shares(robots: int, processes: int) -> list[int]:
    """`robots` spread over `processes` as evenly as can be (the first get one more)."""
    return [robots // processes + (1 if i < robots % processes else 0) for i in range(processes)]


def passed_on(argv: Sequence[str]) -> list[str]:
    """The public server's arguments that its fleet processes get as they are."""
    out: list[str] = []
    skip = False
    for arg in argv:
        if skip:
            skip = False
            continue
        name = arg.split("=", 1)[0]
        if name in OWN_FLAGS:
            skip = OWN_FLAGS[name] and "=" not in arg
            continue
        out.append(arg)
    return out


class Fleet:
    """The fleet processes (and the shared Chroma server) behind one router; started on entry."""

    def __init__(
        self,
        argv: Sequence[str],
        *,
        robots: int,
        processes: int,
        allowed_hosts: Sequence[str],
        auth_token: str | None,
        data_dir: Path | None,
        memory_url: str | None,
        session_idle_s: float,
    ) -> None:
        if processes > robots:
            raise ConfigError(f"--processes {processes} is more than --robots {robots}: a process hosts robots")
        self.upstreams = [Upstream(i, free_port(), n) for i, n in enumerate(shares(robots, processes))]
        self.argv = passed_on(argv)
        self.allowed_hosts = list(allowed_hosts)
        self.auth_token = auth_token
        self.data_dir = data_dir
        self.memory_url = memory_url
        self.session_idle_s = session_idle_s
        self.chroma: subprocess.Popen[bytes] | None = None
        self.driver_secret = secrets.token_hex(32)

    def __enter__(self) -> Router:
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        ids = DriverIds(secret=self.driver_secret.encode())  # the router counts only handles its processes minted
        return Router(self.upstreams, idle_s=self.session_idle_s, token=self.auth_token, restart=self.restart, ids=ids)

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> None:
        env = {**os.environ, "ANONYMIZED_TELEMETRY": "False"}
        env.pop("ROBOCOG_AUTH_TOKEN", None)
        env[DRIVER_SECRET_ENV] = self.driver_secret  # every process (and a restarted one) checks the same ids
        if self.auth_token is not None:
            env["ROBOCOG_AUTH_TOKEN"] = self.auth_token  # not on the command line, where `ps` shows it
        self.env = env
        self.started_memory_url = self.memory_url or self._start_chroma(env)
        for upstream in self.upstreams:
            self._spawn(upstream)
        for upstream in self.upstreams:
            assert upstream.proc is not None
            wait_started(upstream.port, upstream.proc, f"fleet process {upstream.index}")

    def _spawn(self, upstream: Upstream) -> None:
        args = [
            *self.argv,  # first: the router's own flags below are the last word
            *("--transport", "http", "--host", "127.0.0.1", "--port", str(upstream.port)),
            *("--robots", str(upstream.robots), "--processes", "1"),
            # room for sessions that only initialized (the router stops counting them after INIT_ONLY_S)
            *("--max-sessions", str(2 * upstream.robots + 8), "--memory-url", self.started_memory_url),
            *(f"--allowed-host={h}" for h in self.allowed_hosts),
        ]
        upstream.proc = subprocess.Popen(
            [sys.executable, "-m", "robocog.server.cli", *args],
            env=self.env
            | {
                "ROBOCOG_FLEET_PROCESS": f"{upstream.index + 1}/{len(self.upstreams)}",
                "ROBOCOG_FLEET_ROBOTS": str(sum(u.robots for u in self.upstreams)),
                PARENT_ENV: str(os.getpid()),
            },
            stdout=sys.stderr.buffer,
        )

    def restart(self, upstream: Upstream) -> None:
        """Start a process that died again: the same port, robots and memory (blocking)."""
        if upstream.proc is not None and upstream.proc.poll() is None:
            upstream.proc.kill()
        if upstream.proc is not None:
            upstream.proc.wait()
        self._spawn(upstream)
        assert upstream.proc is not None
        wait_started(upstream.port, upstream.proc, f"fleet process {upstream.index}")

    def _start_chroma(self, env: dict[str, str]) -> str:
        from robocog.shared.memory_names import default_data_dir

        path = self.data_dir or default_data_dir()
        path.mkdir(parents=True, exist_ok=True)
        port = free_port()
        chroma = Path(sys.executable).parent / "chroma"
        command = (
            [str(chroma)] if chroma.exists() else [sys.executable, "-c", "from chromadb.cli.cli import app; app()"]
        )
        self.chroma = subprocess.Popen(
            [*command, "run", "--path", str(path), "--host", "127.0.0.1", "--port", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=die_with_parent if os.name == "posix" else None,  # Windows takes no preexec_fn
        )
        wait_started(port, self.chroma, "the shared memory (chroma run)")
        return f"http://127.0.0.1:{port}"

    def stop(self) -> None:
        procs = [u.proc for u in self.upstreams if u.proc is not None] + ([self.chroma] if self.chroma else [])
        for proc in procs:
            if proc.poll() is None:
                proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def wait_started(port: int, proc: subprocess.Popen[bytes], what: str) -> None:
    problem = wait_listening(port, proc, START_TIMEOUT_S)
    if problem is not None:
        before = " before it listened (see its log above)" if problem.startswith("exited") else ""
        raise ConfigError(f"{what} {problem}{before}")


def exit_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(0)


def serve(router: Router, host: str, port: int, log_level: str) -> None:
    """Serve until SIGINT or SIGTERM. uvicorn shuts down gracefully, then raises the signal again
    for the handler it found: ours raises SystemExit, so the caller's `with Fleet(...)` stops the
    processes (the default handler would end this process at once and leave them running)."""

    import anyio
    import uvicorn

    signal.signal(signal.SIGTERM, exit_on_sigterm)
    config = uvicorn.Config(
        router.app(),
        host=host.strip("[]"),
        port=port,
        log_level=log_level.lower(),
        lifespan="on",
        timeout_keep_alive=SERVER_KEEP_ALIVE_S,
    )
    anyio.run(uvicorn.Server(config).serve, backend_options=event_loop_options())
