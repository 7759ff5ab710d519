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
from collections.abc import Callable, Sequence
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
#: How long a session that only initialized counts toward its process's robots (a burst of new
#: sessions spreads over the processes; a client that vanished after initialize stops counting).
INIT_ONLY_S = 30.0
#: How often the router looks at its processes (a dead one is noticed within this).
WATCH_S = 0.25
#: How long a request waits for a process to start answering (a stopped process: a timeout, not a hang).
ANSWER_TIMEOUT_S = 60.0
#: Methods that do not make a session active (the handshake).
_HANDSHAKE = {"initialize", "notifications/initialized", "ping"}
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
    #: Sessions that made a request beyond the handshake (they hold, or may hold, a robot); a session
    #: that only initialized counts for `INIT_ONLY_S` after it opened, then no more.
    active: set[str] = field(default_factory=set)
    opened: dict[str, float] = field(default_factory=dict)
    #: Set while the process is being started again after it died.
    restarting: bool = False
    #: Whether the process is stopped (SIGSTOP): new sessions go elsewhere, its requests time out.
    stopped: bool = False

    def load(self, now: float | None = None) -> float:
        now = time.monotonic() if now is None else now
        fresh = sum(1 for sid, t in self.opened.items() if sid not in self.active and now - t < INIT_ONLY_S)
        return (len(self.active) + fresh + self.pending) / max(1, self.robots)

    def serving(self) -> bool:
        """Running, answering, and not being restarted."""
        return not self.restarting and not self.stopped and (self.proc is None or self.proc.poll() is None)


class Router:
    """Routes MCP requests to the fleet processes (see the module's docstring)."""

    def __init__(
        self,
        upstreams: list[Upstream],
        *,
        idle_s: float = DEFAULT_SESSION_IDLE_S,
        token: str | None = None,
        restart: Callable[[Upstream], None] | None = None,
    ) -> None:
        self.upstreams = upstreams
        self.idle_s = idle_s
        #: Checked here too, before a body is read (the processes check it again).
        self.token = token
        self.by_session: dict[str, Upstream] = {}
        #: Sessions of a process that died (session id -> its process's number), told so once.
        self.lost: dict[str, int] = {}
        #: Starts a dead process again on its port (blocking; the router runs it on a thread).
        self.restart = restart
        #: How long a request waits for its process to start answering.
        self.answer_timeout_s = float(os.environ.get("ROBOCOG_ROUTER_ANSWER_TIMEOUT_S") or ANSWER_TIMEOUT_S)
        self._client: httpx2.AsyncClient | None = None

    def pick(self, body: bytes | dict[str, Any]) -> Upstream:
        """The process for a request without a session id: the one that issued its driver id if it
        gives one (a sessionless client keeps its robot), else the least loaded of those serving
        (a new session)."""
        self._forget_idle()
        message = body if isinstance(body, dict) else _message(body)
        alive = [u for u in self.upstreams if u.serving()] or self.upstreams
        driver = _driver_name(message)
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
            upstream.active.discard(sid)
            upstream.opened.pop(sid, None)

    # --- the processes' health ----------------------------------------------------------------

    async def watch(self) -> None:
        """Forever: notice a process that died (within `WATCH_S`) or was stopped, say so in one
        line, and start a dead one again on its port and memory (its sessions are gone)."""
        import anyio
        import anyio.to_thread

        while True:
            for upstream in self.upstreams:
                proc = upstream.proc
                if proc is None or upstream.restarting:
                    continue
                code = proc.poll()
                if code is None:
                    stopped = _is_stopped(proc.pid)
                    if stopped != upstream.stopped:
                        upstream.stopped = stopped
                        what = (
                            "is stopped (SIGSTOP): new sessions go elsewhere and its requests time out"
                            if stopped
                            else "runs again"
                        )
                        _say(f"fleet process {upstream.index + 1} (pid {proc.pid}) {what}")
                    continue
                if self.restart is None:
                    continue
                upstream.restarting = True
                upstream.stopped = False
                how = f"signal {-code}" if code < 0 else f"exit code {code}"
                for sid in list(upstream.sessions):
                    self._forget(sid)
                    self.lost[sid] = upstream.index + 1
                    while len(self.lost) > 10_000:  # bounded: the oldest are forgotten
                        self.lost.pop(next(iter(self.lost)))
                _say(
                    f"fleet process {upstream.index + 1} (pid {proc.pid}) died ({how}); restarting it on port "
                    f"{upstream.port} with the same memory"
                )
                started = time.monotonic()
                try:
                    await anyio.to_thread.run_sync(self.restart, upstream)
                except Exception as exc:  # reported; tried again on the next look
                    _say(f"fleet process {upstream.index + 1} could not be restarted: {exc}")
                else:
                    assert upstream.proc is not None
                    _say(
                        f"fleet process {upstream.index + 1} is back (pid {upstream.proc.pid}, "
                        f"{time.monotonic() - started:.1f} s): all {sum(u.robots for u in self.upstreams)} robots "
                        "serve again"
                    )
                finally:
                    upstream.restarting = False
            await anyio.sleep(WATCH_S)

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
        try:
            message = _message(bytes(body))
        except RecursionError:
            return _error(400, "Parse error: the JSON is nested too deeply", code=-32700)
        method = message.get("method")
        sid = request.headers.get("mcp-session-id")
        if sid is not None:
            upstream = self.by_session.get(sid)
            if upstream is None:
                died = self.lost.pop(sid, None)
                if died is not None:
                    return _error(
                        404,
                        f"Session not found: robocog-server's fleet process {died} died and was restarted; its "
                        "sessions are gone: start a new session (initialize) and begin the task again",
                        code=-32600,
                    )
                return _error(404, "Session not found", code=-32600)
            if method is not None and method not in _HANDSHAKE:
                upstream.active.add(sid)
            return await self._forward(request, bytes(body), upstream, sid)
        upstream = self.pick(message)
        if method != "initialize":
            return await self._forward(request, bytes(body), upstream, None)
        if upstream.load() >= 1 or not upstream.serving():  # every serving process's robots are taken
            return _error(503, self._full())
        upstream.pending += 1  # counted at once: a burst of new sessions spreads over the processes
        try:
            return await self._forward(request, bytes(body), upstream, None)
        finally:
            upstream.pending -= 1

    def _full(self) -> str:
        """Why a new session is refused: the robots are taken, or some are in a process that is
        being restarted or is stopped (never "driven by others" when the truth is a process)."""
        robots = sum(u.robots for u in self.upstreams)
        down = [u for u in self.upstreams if not u.serving()]
        if down:
            which = ", ".join(
                f"{u.index + 1} ({u.robots} robots, {'stopped' if u.stopped else 'restarting after it died'})"
                for u in down
            )
            return (
                f"robocog-server: {sum(u.robots for u in down)} of the {robots} robots are unavailable: fleet "
                f"process {which}; the others are driven by other sessions. Retry in a few seconds"
            )
        return (
            f"robocog-server: all {robots} robots of this server are driven by other sessions (--robots "
            f"{robots}); close a session (HTTP DELETE /mcp with its Mcp-Session-Id), wait for one to idle "
            f"out ({self.idle_s:g} s), or start the server with more robots"
        )

    async def _forward(self, request: Request, body: bytes, upstream: Upstream, sid: str | None) -> Response:
        """Send the request to `upstream` and stream its answer back (the session stays in flight
        until the answer's last byte: a GET stream for as long as it is open)."""
        import anyio
        import httpx2
        from starlette.background import BackgroundTask
        from starlette.responses import StreamingResponse

        if self._client is None:
            # No read timeout (a GET stream is quiet for minutes); the time to an answer is bounded below.
            timeout = httpx2.Timeout(None, connect=10.0)
            self._client = httpx2.AsyncClient(timeout=timeout, limits=httpx2.Limits(max_connections=None))
        headers = [(k, v) for k, v in request.headers.raw if k.decode("latin-1").lower() != "content-length"]
        outgoing = self._client.build_request(
            request.method, upstream.url, params=request.url.query, headers=headers, content=body
        )
        if sid is not None:
            upstream.inflight[sid] = upstream.inflight.get(sid, 0) + 1
        try:
            with anyio.fail_after(self.answer_timeout_s):
                response = await self._client.send(outgoing, stream=True)
        except (httpx2.HTTPError, TimeoutError) as exc:
            self._ended(upstream, sid)
            why = (
                "is being restarted after it died"
                if upstream.restarting
                else f"did not answer within {self.answer_timeout_s:g} s (stopped?)"
                if isinstance(exc, TimeoutError)
                else f"is not answering ({type(exc).__name__})"
            )
            return _error(502, f"robocog-server: fleet process {upstream.index + 1} {why}; retry in a few seconds")
        new_sid = response.headers.get("mcp-session-id")
        if sid is None and new_sid and response.status_code < 400:
            self.by_session[new_sid] = upstream
            upstream.sessions[new_sid] = upstream.opened[new_sid] = time.monotonic()
        if sid is not None and (response.status_code == 404 or (request.method == "DELETE" and response.is_success)):
            self._forget(sid)

        async def done() -> None:
            await response.aclose()
            self._ended(upstream, sid)

        kept = [(k, v) for k, v in response.headers.raw if k.decode("latin-1").lower() not in _HOP_HEADERS]

        async def relay() -> Any:
            """The answer's bytes; a process that dies mid-answer ends the stream (one line, no traceback)."""
            try:
                async for chunk in response.aiter_raw():
                    yield chunk
            except httpx2.HTTPError as exc:
                logger.info("fleet process %d cut a stream (%s)", upstream.index + 1, type(exc).__name__)

        streamed = StreamingResponse(relay(), status_code=response.status_code, background=BackgroundTask(done))
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
            import anyio

            async with anyio.create_task_group() as tg:
                tg.start_soon(self.watch)
                yield
                tg.cancel_scope.cancel()
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
    """The JSON-RPC message of a request body ({} when it is none, or not one message); a body
    nested too deeply raises RecursionError (the caller answers it with a parse error)."""
    if not body:
        return {}
    try:
        message = json.loads(body)
    except ValueError:
        return {}
    return message if isinstance(message, dict) else {}


def _driver_name(message: dict[str, Any]) -> str | None:
    """`params._meta["robocog/driver"]` of a JSON-RPC request, if it names one."""
    params = message.get("params")
    meta = params.get("_meta") if isinstance(params, dict) else None
    name = meta.get(DRIVER_META_KEY) if isinstance(meta, dict) else None
    return name if isinstance(name, str) and name else None


def _say(line: str) -> None:
    """One line on the router's stderr, where the processes' logs go too."""
    print(f"robocog-server: {line}", file=sys.stderr, flush=True)


def _is_stopped(pid: int) -> bool:
    """Whether process `pid` is stopped (SIGSTOP), as Linux's /proc says; False where it cannot tell."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[-1].split()[0] in ("T", "t")


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
        return Router(self.upstreams, idle_s=self.session_idle_s, token=self.auth_token, restart=self.restart)

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
            _wait_listening(upstream.port, upstream.proc, f"fleet process {upstream.index}")

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
        _wait_listening(upstream.port, upstream.proc, f"fleet process {upstream.index}")

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
