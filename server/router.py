"""One address in front of several fleet processes (`robocog-server --robots N --processes P`).

PyBullet holds the GIL while it steps, so one fleet process uses about one core. To use more, this
router starts P fleet processes on loopback ports, each with its share of the N robots, and answers
on the public address itself: a new MCP session (an `initialize` without a session id) goes to the
process with the fewest sessions for its robots, and every later request of that session (its
`Mcp-Session-Id`) to the same process, streamed through both ways (SSE included). A client without
sessions (MCP 2026-07-28) goes to the least loaded process for its first call, and then to the
process that issued its driver id (`_meta["robocog/driver"]` names it), so it keeps its robot too;
the processes share the secret that signs the ids. The router never looks inside a session: the
bearer token, Host and Origin are checked by the fleet processes, which get the same token (in
their environment) and accept the public address's names.

The robots of all processes share one memory, as the robots of one process do: unless
`--memory-url` names a Chroma server, the router starts one (`chroma run`, shipped with chromadb)
on the data directory, on loopback, and points every process at it.

The router imports neither the MCP SDK nor PyBullet: it starts in a fraction of a second and costs
about 60 MB.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import logging
import os
import secrets
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.server.config import DEFAULT_SESSION_IDLE_S, DRIVER_SECRET_ENV
from robocog.shared.errors import ConfigError
from robocog.shared.process import PARENT_ENV, die_with_parent, free_port, wait_listening
from robocog.shared.protocol import DRIVER_META_KEY

if TYPE_CHECKING:
    import httpx2
    from starlette.requests import Request
    from starlette.responses import Response

logger = logging.getLogger("robocog.server.router")

#: Flags of the public server that its fleet processes get in another form (or not at all), and
#: whether each takes a value.
_OWN_FLAGS = {
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
#: Response headers that belong to one hop, not to the message.
_HOP_HEADERS = {"connection", "keep-alive", "transfer-encoding", "te", "trailer", "upgrade"}
START_TIMEOUT_S = 90.0
#: The largest request body passed on (the SDK's own limit for streamable HTTP).
MAX_BODY = 4 * 1024 * 1024


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
        if name in _OWN_FLAGS:
            skip = _OWN_FLAGS[name] and "=" not in arg
            continue
        out.append(arg)
    return out


@dataclass
class Upstream:
    """One fleet process: its port, its robots, and its sessions (id -> when last used)."""

    index: int
    port: int
    robots: int
    proc: subprocess.Popen[bytes] | None = None
    sessions: dict[str, float] = field(default_factory=dict)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/mcp"

    #: Requests in flight per session; new sessions being opened (not yet answered).
    inflight: dict[str, int] = field(default_factory=dict)
    pending: int = 0

    def load(self) -> float:
        return (len(self.sessions) + self.pending) / max(1, self.robots)


class Router:
    """Routes MCP requests to the fleet processes (see the module's docstring)."""

    def __init__(
        self, upstreams: list[Upstream], *, idle_s: float = DEFAULT_SESSION_IDLE_S, token: str | None = None
    ) -> None:
        self.upstreams = upstreams
        self.idle_s = idle_s
        #: Checked here too, before a body is read (the processes check it again).
        self.token = token
        self.by_session: dict[str, Upstream] = {}
        self._client: httpx2.AsyncClient | None = None

    def pick(self, body: bytes) -> Upstream:
        """The process for a request without a session id: by its driver's name if it gives one
        (a sessionless client keeps its robot), else the least loaded of those still running (a
        new session)."""
        self._forget_idle()
        alive = [u for u in self.upstreams if u.proc is None or u.proc.poll() is None] or self.upstreams
        driver = _driver_name(body)
        if driver is not None:
            origin = driver.split(".", 1)[0]  # an issued id names its process (server/ownership.py)
            if origin.isdigit() and int(origin) < len(self.upstreams):
                return self.upstreams[int(origin)]
            digest = hashlib.sha256(driver.encode()).digest()
            return alive[int.from_bytes(digest[:4], "big") % len(alive)]
        return min(alive, key=lambda u: (u.load(), u.index))

    def _forget_idle(self) -> None:
        """Sessions the processes closed for idleness: quiet for `idle_s` since their last request
        ended, and none in flight (an open GET stream keeps a session alive)."""
        now = time.monotonic()
        for sid, upstream in list(self.by_session.items()):
            if not upstream.inflight.get(sid) and now - upstream.sessions.get(sid, now) > self.idle_s:
                self._forget(sid)

    def _forget(self, sid: str) -> None:
        upstream = self.by_session.pop(sid, None)
        if upstream is not None:
            upstream.sessions.pop(sid, None)
            upstream.inflight.pop(sid, None)

    def _authorized(self, request: Request) -> bool:
        if self.token is None:
            return True
        given = request.headers.get("authorization", "")
        return hmac.compare_digest(given.encode(), f"Bearer {self.token}".encode())

    async def handle(self, request: Request) -> Response:
        from starlette.responses import JSONResponse

        if not self._authorized(request):
            return JSONResponse(
                {"error": "invalid_token", "error_description": "Authentication required"},
                401,
                headers={"www-authenticate": 'Bearer error="invalid_token"'},
            )
        body = bytearray()
        async for chunk in request.stream():
            body += chunk
            if len(body) > MAX_BODY:
                return _error(413, f"robocog-server: a request body of more than {MAX_BODY} bytes is refused")
        sid = request.headers.get("mcp-session-id")
        if sid is not None:
            upstream = self.by_session.get(sid)
            if upstream is None:
                return _error(404, "Session not found", code=-32600)
            return await self._forward(request, bytes(body), upstream, sid)
        upstream = self.pick(bytes(body))
        if _method(bytes(body)) != "initialize":
            return await self._forward(request, bytes(body), upstream, None)
        if upstream.load() >= 1:  # every process's robots are taken
            robots = sum(u.robots for u in self.upstreams)
            return _error(
                503,
                f"robocog-server: all {robots} robots of this server are driven by other sessions (--robots "
                f"{robots}); close a session (HTTP DELETE /mcp with its Mcp-Session-Id), wait for one to idle "
                f"out ({self.idle_s:g} s), or start the server with more robots",
            )
        upstream.pending += 1  # counted at once: a burst of new sessions spreads over the processes
        try:
            return await self._forward(request, bytes(body), upstream, None)
        finally:
            upstream.pending -= 1

    async def _forward(self, request: Request, body: bytes, upstream: Upstream, sid: str | None) -> Response:
        """Send the request to `upstream` and stream its answer back (the session stays in flight
        until the answer's last byte: a GET stream for as long as it is open)."""
        import httpx2
        from starlette.background import BackgroundTask
        from starlette.responses import StreamingResponse

        if self._client is None:
            self._client = httpx2.AsyncClient(timeout=httpx2.Timeout(None), limits=httpx2.Limits(max_connections=None))
        headers = [(k, v) for k, v in request.headers.raw if k.decode("latin-1").lower() != "content-length"]
        outgoing = self._client.build_request(
            request.method, upstream.url, params=request.url.query, headers=headers, content=body
        )
        if sid is not None:
            upstream.inflight[sid] = upstream.inflight.get(sid, 0) + 1
        try:
            response = await self._client.send(outgoing, stream=True)
        except httpx2.HTTPError as exc:
            self._ended(upstream, sid)
            return _error(
                502, f"robocog-server: fleet process {upstream.index} is not answering ({type(exc).__name__})"
            )
        new_sid = response.headers.get("mcp-session-id")
        if sid is None and new_sid and response.status_code < 400:
            self.by_session[new_sid] = upstream
            upstream.sessions[new_sid] = time.monotonic()
        if sid is not None and (response.status_code == 404 or (request.method == "DELETE" and response.is_success)):
            self._forget(sid)

        async def done() -> None:
            await response.aclose()
            self._ended(upstream, sid)

        kept = [(k, v) for k, v in response.headers.raw if k.decode("latin-1").lower() not in _HOP_HEADERS]
        streamed = StreamingResponse(
            response.aiter_raw(), status_code=response.status_code, background=BackgroundTask(done)
        )
        streamed.raw_headers = [(k.lower(), v) for k, v in kept]
        return streamed

    def _ended(self, upstream: Upstream, sid: str | None) -> None:
        if sid is None or sid not in upstream.inflight:
            return
        upstream.inflight[sid] -= 1
        if sid in upstream.sessions:
            upstream.sessions[sid] = time.monotonic()

    def app(self) -> Any:
        from starlette.applications import Starlette
        from starlette.routing import Route

        async def closing() -> Any:
            yield
            if self._client is not None:
                await self._client.aclose()

        return Starlette(
            routes=[Route("/mcp", self.handle, methods=["GET", "POST", "DELETE"])],
            lifespan=lambda _: contextlib.asynccontextmanager(closing)(),
        )


def _error(status: int, message: str, *, code: int = -32603) -> Response:
    from starlette.responses import JSONResponse

    return JSONResponse({"jsonrpc": "2.0", "id": None, "error": {"code": code, "message": message}}, status)


def _message(body: bytes) -> dict[str, Any]:
    """The JSON-RPC message of a request body ({} when it is none)."""
    if not body or len(body) > 1_000_000:
        return {}
    try:
        message = json.loads(body)
    except ValueError:
        return {}
    return message if isinstance(message, dict) else {}


def _method(body: bytes) -> str | None:
    method = _message(body).get("method")
    return method if isinstance(method, str) else None


def _driver_name(body: bytes) -> str | None:
    """`params._meta["robocog/driver"]` of a JSON-RPC request, if it names one."""
    params = _message(body).get("params")
    meta = params.get("_meta") if isinstance(params, dict) else None
    name = meta.get(DRIVER_META_KEY) if isinstance(meta, dict) else None
    return name if isinstance(name, str) and name else None


# --- starting and stopping the processes ---------------------------------------------------------


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
        return Router(self.upstreams, idle_s=self.session_idle_s, token=self.auth_token)

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> None:
        env = {**os.environ, "ANONYMIZED_TELEMETRY": "False"}
        env.pop("ROBOCOG_AUTH_TOKEN", None)
        env[DRIVER_SECRET_ENV] = self.driver_secret  # every process (and a restarted one) checks the same ids
        if self.auth_token is not None:
            env["ROBOCOG_AUTH_TOKEN"] = self.auth_token  # not on the command line, where `ps` shows it
        memory_url = self.memory_url or self._start_chroma(env)
        for upstream in self.upstreams:
            args = [
                *self.argv,  # first: the router's own flags below are the last word
                *("--transport", "http", "--host", "127.0.0.1", "--port", str(upstream.port)),
                *("--robots", str(upstream.robots), "--processes", "1"),
                *("--max-sessions", str(upstream.robots + 4), "--memory-url", memory_url),
                *(f"--allowed-host={h}" for h in self.allowed_hosts),
            ]
            upstream.proc = subprocess.Popen(
                [sys.executable, "-m", "robocog.server.cli", *args],
                env=env
                | {
                    "ROBOCOG_FLEET_PROCESS": f"{upstream.index + 1}/{len(self.upstreams)}",
                    PARENT_ENV: str(os.getpid()),
                },
                stdout=sys.stderr.buffer,
            )
        for upstream in self.upstreams:
            assert upstream.proc is not None
            _wait_listening(upstream.port, upstream.proc, f"fleet process {upstream.index}")

    def _start_chroma(self, env: dict[str, str]) -> str:
        from robocog.server.memory.names import default_data_dir

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
            preexec_fn=die_with_parent,
        )
        _wait_listening(port, self.chroma, "the shared memory (chroma run)")
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


def _wait_listening(port: int, proc: subprocess.Popen[bytes], what: str) -> None:
    problem = wait_listening(port, proc, START_TIMEOUT_S)
    if problem is not None:
        before = " before it listened (see its log above)" if problem.startswith("exited") else ""
        raise ConfigError(f"{what} {problem}{before}")


def _exit_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(0)


def serve(router: Router, host: str, port: int, log_level: str) -> None:
    """Serve until SIGINT or SIGTERM. uvicorn shuts down gracefully, then raises the signal again
    for the handler it found: ours raises SystemExit, so the caller's `with Fleet(...)` stops the
    processes (the default handler would end this process at once and leave them running)."""
    import signal

    import anyio
    import uvicorn

    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    config = uvicorn.Config(router.app(), host=host.strip("[]"), port=port, log_level=log_level.lower(), lifespan="on")
    anyio.run(uvicorn.Server(config).serve)
