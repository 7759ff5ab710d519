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
import logging
import os
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from robocog.server.config import DEFAULT_SESSION_IDLE_S, UNCONFIRMED_IDLE_S
from robocog.server.robots.handles import DriverIds
from robocog.server.routing.router_wire import driver_name, error_response, is_stopped, mints_handle, parse_message, say
from robocog.shared.web import CLIENT_KEEP_ALIVE_S

if TYPE_CHECKING:
    import httpx2
    from starlette.requests import Request
    from starlette.responses import Response

logger = logging.getLogger("robocog.server.router")

#: Response headers that belong to one hop, not to the message.
_HOP_HEADERS = {"connection", "keep-alive", "transfer-encoding", "te", "trailer", "upgrade"}
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
    #: Robot handles of sessionless clients that this process minted, as last presented (handle -> when),
    #: and the id-less calls sent here that mint one, not yet presented (when each was sent).
    handles: dict[str, float] = field(default_factory=dict)
    minting: list[float] = field(default_factory=list)

    def load(self, now: float | None = None) -> float:
        now = time.monotonic() if now is None else now
        fresh = sum(1 for sid, t in self.opened.items() if sid not in self.active and now - t < INIT_ONLY_S)
        held = len(self.active) + fresh + self.pending + len(self.handles) + len(self.minting)
        return held / max(1, self.robots)

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
        ids: DriverIds | None = None,
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
        #: Checks a presented handle's signature (the processes' secret): a forged one is not counted
        #: as a process's load, nor kept (the process refuses its call).
        self.ids = ids
        #: How long a request waits for its process to start answering.
        self.answer_timeout_s = float(os.environ.get("ROBOCOG_ROUTER_ANSWER_TIMEOUT_S") or ANSWER_TIMEOUT_S)
        self._client: httpx2.AsyncClient | None = None

    def pick(self, body: bytes | dict[str, Any]) -> Upstream:
        """The process for a request without a session id: the one that minted the robot handle it
        presents (`robot_id`, or its `_meta` alias: a sessionless client keeps its robot), else the least
        loaded of those serving (a new session, or a call that mints a handle, which counts there
        until it is presented or `UNCONFIRMED_IDLE_S` passes)."""
        self._forget_idle()
        now = time.monotonic()
        message = body if isinstance(body, dict) else parse_message(body)
        alive = [u for u in self.upstreams if u.serving()] or self.upstreams
        driver = driver_name(message)
        if driver is not None and self.ids is not None and not self.ids.valid(driver):
            driver = None  # forged: the least loaded process refuses it, and nothing is counted
        if driver is not None:
            origin = driver.split(".", 1)[0]  # a minted handle names its process (server/robots/ownership.py)
            if origin.isdigit() and int(origin) < len(self.upstreams):
                upstream = self.upstreams[int(origin)]
                if driver not in upstream.handles and upstream.minting:
                    upstream.minting.pop(0)  # the handle minted there is presented: counted once, as a handle
                upstream.handles[driver] = now
                return upstream
            digest = hashlib.sha256(driver.encode()).digest()
            return alive[int.from_bytes(digest[:4], "big") % len(alive)]
        upstream = min(alive, key=lambda u: (u.load(now), u.index))
        if mints_handle(message) and driver_name(message) is None:
            upstream.minting.append(now)
        return upstream

    def _forget_idle(self) -> None:
        """Sessions the processes closed for idleness: quiet for `idle_s` since their last request
        ended, and none in flight (an open GET stream keeps a session alive); handles as silent as
        that, and minting calls whose handle was not presented within `UNCONFIRMED_IDLE_S`."""
        now = time.monotonic()
        for sid, upstream in list(self.by_session.items()):
            if not upstream.inflight.get(sid) and now - upstream.sessions.get(sid, now) > self.idle_s:
                self._forget(sid)
        for upstream in self.upstreams:
            for handle, last in list(upstream.handles.items()):
                if now - last > self.idle_s:
                    del upstream.handles[handle]
            upstream.minting[:] = [t for t in upstream.minting if now - t < UNCONFIRMED_IDLE_S]

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
                    stopped = is_stopped(proc.pid)
                    if stopped != upstream.stopped:
                        upstream.stopped = stopped
                        what = (
                            "is stopped (SIGSTOP): new sessions go elsewhere and its requests time out"
                            if stopped
                            else "runs again"
                        )
                        say(f"fleet process {upstream.index + 1} (pid {proc.pid}) {what}")
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
                say(
                    f"fleet process {upstream.index + 1} (pid {proc.pid}) died ({how}); restarting it on port "
                    f"{upstream.port} with the same memory"
                )
                started = time.monotonic()
                try:
                    await anyio.to_thread.run_sync(self.restart, upstream)
                except Exception as exc:  # reported; tried again on the next look
                    say(f"fleet process {upstream.index + 1} could not be restarted: {exc}")
                else:
                    assert upstream.proc is not None
                    say(
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
        # as the SDK's auth middleware reads it in the fleet processes: the scheme in any case (RFC 7235)
        scheme, _, given = request.headers.get("authorization", "").partition(" ")
        return scheme.lower() == "bearer" and hmac.compare_digest(given.encode(), self.token.encode())

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
                return error_response(413, f"robocog-server: a request body of more than {MAX_BODY} bytes is refused")
        try:
            message = parse_message(bytes(body))
        except RecursionError:
            return error_response(400, "Parse error: the JSON is nested too deeply", code=-32700)
        method = message.get("method")
        sid = request.headers.get("mcp-session-id")
        if sid is not None:
            upstream = self.by_session.get(sid)
            if upstream is None:
                died = self.lost.pop(sid, None)
                if died is not None:
                    return error_response(
                        404,
                        f"Session not found: robocog-server's fleet process {died} died and was restarted; its "
                        "sessions are gone: start a new session (initialize) and begin the task again",
                        code=-32600,
                    )
                return error_response(404, "Session not found", code=-32600)
            if method is not None and method not in _HANDSHAKE:
                upstream.active.add(sid)
            return await self._forward(request, bytes(body), upstream, sid)
        upstream = self.pick(message)
        if method != "initialize":
            return await self._forward(request, bytes(body), upstream, None)
        if upstream.load() >= 1 or not upstream.serving():  # every serving process's robots are taken
            return error_response(503, self._full())
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
            # Idle connections to the processes kept as long as a client's to the router (see shared.web).
            limits = httpx2.Limits(max_connections=None, keepalive_expiry=CLIENT_KEEP_ALIVE_S)
            self._client = httpx2.AsyncClient(timeout=timeout, limits=limits)
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
            return error_response(
                502, f"robocog-server: fleet process {upstream.index + 1} {why}; retry in a few seconds"
            )
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


# --- starting and stopping the processes ---------------------------------------------------------
