"""The robot over streamable HTTP: who may connect, how many at once, and for how long.

- **Bind**: loopback by default. Binding to any other address refuses to start without a bearer
  token, so a robot is never exposed to a network unauthenticated.
- **Bearer token** (`--auth-token`, `$ROBOCOG_AUTH_TOKEN`, or `--auth-token generate`): every request
  to /mcp carries `Authorization: Bearer TOKEN`; without it 401, with a wrong one 401. Checked by
  the MCP SDK's own auth middleware through a `TokenVerifier` (`BearerToken` below), compared in
  constant time. TLS is a reverse proxy's job (docs/security.md shows one).
- **Host and Origin** are always checked (DNS rebinding): loopback names, the bind address, this
  machine's names, and whatever `--allowed-host`/`--allowed-origin` add; a foreign Host gets 421,
  a foreign Origin 403.
- **Sessions**: at most `--max-sessions` open at once (503 with a message saying so past the cap),
  each closed after `--session-idle-s` without a request, its memory returned; sooner when its
  client is seen gone (`VanishedClients`): its event stream closed for good, or it never went
  beyond `initialize`.
"""

from __future__ import annotations

import contextlib
import hmac
import ipaddress
import math
import secrets
import socket
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from robocog.server.config import DEFAULT_MAX_SESSIONS, DEFAULT_SESSION_IDLE_S, event_loop_options
from robocog.shared.errors import ConfigError
from robocog.shared.web import LOOPBACK_NAMES, SERVER_KEEP_ALIVE_S

# The MCP SDK is imported where it is used: the command line checks its options with this module
# before it pays for the SDK's import (a bad option fails in a fraction of a second).
if TYPE_CHECKING:
    from mcp.server.auth.provider import AccessToken
    from mcp.server.auth.settings import AuthSettings
    from mcp.server.mcpserver import MCPServer
    from mcp.server.transport_security import TransportSecuritySettings
    from starlette.types import ASGIApp, Message, Receive, Scope, Send

    from robocog.server.robots.ownership import Presence

#: The shortest token accepted: a guessable token is no protection.
MIN_TOKEN_LENGTH = 16


@dataclass(frozen=True)
class HttpOptions:
    host: str = "127.0.0.1"
    port: int = 8765
    auth_token: str | None = None
    allowed_hosts: tuple[str, ...] = ()
    allowed_origins: tuple[str, ...] = ()
    max_sessions: int = DEFAULT_MAX_SESSIONS
    session_idle_s: float = DEFAULT_SESSION_IDLE_S
    #: Answer each POST with one JSON body, not an event stream (`--json-response`).
    json_response: bool = False
    #: Added to every Host check (tests and `--allowed-host`); the machine's names are found at start.
    machine_names: tuple[str, ...] = field(default_factory=tuple)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/mcp"

    @property
    def loopback(self) -> bool:
        return is_loopback(self.host)

    def check(self) -> None:
        """Refuse what would be unsafe or cannot work, with the flag to change (a `ConfigError`)."""
        if not self.loopback and not self.auth_token:
            raise ConfigError(
                f"--host {self.host}: binding to an address other than loopback exposes the robot to the network; "
                "give --auth-token TOKEN (or set ROBOCOG_AUTH_TOKEN, or --auth-token generate) so clients must "
                "authenticate"
            )
        if self.auth_token is not None and len(self.auth_token) < MIN_TOKEN_LENGTH:
            raise ConfigError(f"--auth-token: at least {MIN_TOKEN_LENGTH} characters (or --auth-token generate)")
        if self.max_sessions < 1:
            raise ConfigError(f"--max-sessions: {self.max_sessions} is not a positive number of sessions")
        if not (math.isfinite(self.session_idle_s) and self.session_idle_s > 0):
            raise ConfigError(f"--session-idle-s: {self.session_idle_s} is not a positive number of seconds")
        if not 0 <= self.port <= 65535:
            raise ConfigError(f"--port: {self.port} is not a TCP port (0-65535)")

    def host_names(self) -> list[str]:
        """The Host values accepted: loopback names, this machine's, the bind address, and `--allowed-host`'s."""
        hosts = [*LOOPBACK_NAMES, *self.machine_names, *self.allowed_hosts]
        if not self.loopback and not is_wildcard(self.host):
            hosts.append(f"[{self.host}]" if ":" in self.host else self.host)
        # A name without a port is allowed with any port, and bare (port 80 behind a proxy).
        return sorted({form for h in hosts for form in ((h,) if has_port(h) else (h, f"{h}:*"))})

    def transport_security(self) -> TransportSecuritySettings:
        """Host and Origin checks on, whatever the bind address."""
        from mcp.server.transport_security import TransportSecuritySettings

        allowed_hosts = self.host_names()
        origins = [f"http://{h}:*" for h in LOOPBACK_NAMES] + [f"https://{h}:*" for h in LOOPBACK_NAMES]
        return TransportSecuritySettings(
            enable_dns_rebinding_protection=True,
            allowed_hosts=allowed_hosts,
            allowed_origins=sorted({*origins, *self.allowed_origins}),
        )


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def has_port(host: str) -> bool:
    """Whether a Host value names a port: `name:8765`, `[::1]:8765` (not `[::1]`)."""
    return ":" in host.rsplit("]", 1)[-1]


def is_wildcard(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_unspecified
    except ValueError:
        return False


def machine_names() -> tuple[str, ...]:
    """This machine's names and addresses, as a client on the network would put them in Host."""
    names = {socket.gethostname(), socket.getfqdn()}
    with contextlib.suppress(OSError):
        names.update(socket.gethostbyname_ex(socket.gethostname())[2])
    return tuple(sorted(n for n in names if n))


def generate_token() -> str:
    return secrets.token_urlsafe(32)


class BearerToken:
    """The SDK's `TokenVerifier` for one shared secret (compared in constant time)."""

    def __init__(self, token: str) -> None:
        self._token = token.encode()

    async def verify_token(self, token: str) -> AccessToken | None:
        from mcp.server.auth.provider import AccessToken

        if hmac.compare_digest(token.encode(), self._token):
            return AccessToken(token=token, client_id="robocog-bearer", scopes=[])
        return None


def auth_settings(url: str) -> AuthSettings:
    """The SDK's auth settings for a resource server with its own static token: no authorization
    server to discover, so no protected-resource metadata (`resource_server_url` is None); the issuer
    is the server itself."""
    from mcp.server.auth.settings import AuthSettings

    return AuthSettings.model_validate({"issuer_url": url, "resource_server_url": None})


class SessionCapMessage:
    """ASGI middleware: the SDK answers a session past the cap with a bare "Too many open sessions";
    say how many, and what to do."""

    def __init__(self, app: ASGIApp, *, max_sessions: int, idle_s: float) -> None:
        self.app = app
        self.body = (
            '{"jsonrpc":"2.0","id":null,"error":{"code":-32603,"message":'
            f'"robocog-server: all {max_sessions} sessions are in use (--max-sessions {max_sessions}); close a '
            f"session you no longer need (HTTP DELETE /mcp with its Mcp-Session-Id) or wait: an idle one is "
            f'closed after {idle_s:g} s (--session-idle-s)"}}}}'
        ).encode()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        replacing = False

        async def rewrite(message: Message) -> None:
            nonlocal replacing
            if message["type"] == "http.response.start" and message["status"] == 503:
                replacing = True
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() != b"content-length"]
                headers.append((b"content-length", str(len(self.body)).encode()))
                message = {**message, "headers": headers}
            elif replacing and message["type"] == "http.response.body":
                if message.get("more_body", False):
                    return  # the SDK's own body is dropped; ours goes with the last chunk
                message = {"type": "http.response.body", "body": self.body}
            await send(message)

        await self.app(scope, receive, rewrite)


#: A session whose client's event stream (its GET) closed, with nothing in flight, is closed this
#: long after, unless the client opens a stream again (its SDK reconnects within a second or two).
GONE_GRACE_S = 5.0
#: A session that never made a request beyond the handshake, and has no stream open, is closed
#: this long after it was opened (its client vanished after `initialize`).
INIT_ONLY_S = 30.0


@dataclass
class _Seen:
    """What the transport shows of one session: its open event streams, its requests in flight,
    how many requests it made, and the request to send its DELETE as (its headers)."""

    scope: dict[str, Any]
    opened: float
    streams: int = 0
    inflight: int = 0
    posts: int = 0
    had_stream: bool = False
    quiet_since: float = 0.0


class VanishedClients:
    """ASGI middleware: free a session's robot promptly when its client is gone, where the transport
    shows it. An MCP client with a session keeps an event stream (a GET) open; when that stream
    closes and is not opened again within `GONE_GRACE_S`, with no request in flight, the client has
    gone (killed, crashed, its machine off the network), and the session is closed as its own
    DELETE would close it (its robot goes back to the pool, its lease ends). A session that never
    went beyond `initialize` (and opened no stream) is closed after `INIT_ONLY_S`. Every other
    session idles out after `--session-idle-s`, as before."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        idle_s: float = DEFAULT_SESSION_IDLE_S,
        clock: Any = None,
        presence: Presence | None = None,
    ) -> None:
        import time

        self.app = app
        self.idle_s = idle_s
        self.clock = clock or time.monotonic
        self.sessions: dict[str, _Seen] = {}
        self.closed = 0
        if presence is not None:  # the robots ask whether a session's client has gone, and close it
            presence.attach(self.absent, self.close_gone)

    def absent(self, sid: str) -> bool:
        """Whether the client of session `sid` has gone as far as the transport shows: the event
        stream it had open is closed and no request of it is in flight (within `GONE_GRACE_S` it could
        still open the stream again; a client that wants the robot meanwhile does not wait for that)."""
        seen = self.sessions.get(sid)
        return seen is not None and seen.had_stream and not seen.streams and not seen.inflight

    async def close_gone(self, sid: str) -> None:
        seen = self.sessions.pop(sid, None)
        if seen is not None:
            await self._close(
                sid, seen, "its client went away (its event stream closed), and another client asked for its robot"
            )

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "lifespan":
            import anyio

            async with anyio.create_task_group() as tg:
                tg.start_soon(self._watch)
                await self.app(scope, receive, send)
                tg.cancel_scope.cancel()
            return
        if scope["type"] != "http" or scope.get("path", "").rstrip("/") != "/mcp":
            await self.app(scope, receive, send)
            return
        sid = _header(scope, b"mcp-session-id")
        method = scope.get("method")
        seen = self.sessions.get(sid) if sid else None
        if method == "DELETE" and sid:
            self.sessions.pop(sid, None)
            await self.app(scope, receive, send)
            return
        if seen is not None:
            seen.inflight += 1
            if method == "GET":
                seen.streams += 1
                seen.had_stream = True
            else:
                seen.posts += 1

        async def watching(message: Message) -> None:
            # A new session (initialize) is known before its client can learn its id, so the event
            # stream the client opens next is counted even while this request is still finishing.
            if message["type"] == "http.response.start" and sid is None and message["status"] < 400:
                for key, value in message.get("headers", []):
                    if key.lower() == b"mcp-session-id":
                        self._remember(scope, value.decode("latin-1"))
            await send(message)

        try:
            await self.app(scope, receive, watching)
        finally:
            now = self.clock()
            if seen is not None:
                seen.inflight -= 1
                if method == "GET":
                    seen.streams -= 1
                seen.quiet_since = now

    def _remember(self, scope: Scope, opened: str) -> None:
        """A new session (initialize): remember how to close it."""
        now = self.clock()
        headers = [(k, v) for k, v in scope.get("headers", []) if k.lower() != b"content-length"]
        headers.append((b"mcp-session-id", opened.encode("latin-1")))
        self.sessions[opened] = _Seen({**scope, "headers": headers}, opened=now, quiet_since=now)

    def gone(self, now: float) -> list[tuple[str, str]]:
        """The sessions to close now, and why (those the SDK has idled out are forgotten)."""
        out = []
        for sid, seen in list(self.sessions.items()):
            if seen.inflight or seen.streams:
                continue
            if now - seen.quiet_since > self.idle_s:
                del self.sessions[sid]
                continue
            if seen.had_stream and now - seen.quiet_since > GONE_GRACE_S:
                out.append((sid, "its client went away (its event stream closed)"))
            elif not seen.had_stream and seen.posts <= 1 and now - seen.opened > INIT_ONLY_S:
                out.append((sid, f"it made no request in {INIT_ONLY_S:g} s after initialize"))
        return out

    async def _watch(self) -> None:
        import anyio

        while True:
            await anyio.sleep(1.0)
            for sid, why in self.gone(self.clock()):
                seen = self.sessions.pop(sid, None)
                if seen is not None:
                    await self._close(sid, seen, why)

    async def _close(self, sid: str, seen: _Seen, why: str) -> None:
        """DELETE the session through the app, with the headers its client sent."""
        import logging

        scope = {**seen.scope, "method": "DELETE", "query_string": b""}

        async def receive() -> Message:
            return {"type": "http.request", "body": b"", "more_body": False}

        async def discard(message: Message) -> None:
            return None

        try:
            await self.app(scope, receive, discard)
        except Exception as exc:  # the session may have ended meanwhile
            logging.getLogger("robocog.server").debug("closing session %s: %s", sid[:8], exc)
            return
        self.closed += 1
        logging.getLogger("robocog.server").info("session %s… closed: %s", sid[:8], why)


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", []):
        if key.lower() == name:
            return str(value.decode("latin-1"))
    return None


def build_app(mcp: MCPServer[Any], options: HttpOptions) -> ASGIApp:
    """The Starlette app of `mcp` with robocog's limits and checks."""
    app = mcp.streamable_http_app(
        host=options.host,
        transport_security=options.transport_security(),
        max_sessions=options.max_sessions,
        session_idle_timeout=options.session_idle_s,
        json_response=options.json_response,
    )
    capped = SessionCapMessage(app, max_sessions=options.max_sessions, idle_s=options.session_idle_s)
    return VanishedClients(capped, idle_s=options.session_idle_s, presence=getattr(mcp, "presence", None))


def serve(mcp: MCPServer[Any], options: HttpOptions, *, log_level: str = "warning") -> None:
    """Serve until interrupted (uvicorn, as the SDK's own `run("streamable-http")` does)."""
    import anyio
    import uvicorn

    config = uvicorn.Config(
        build_app(mcp, options),
        host=options.host.strip("[]"),
        port=options.port,
        log_level=log_level.lower(),
        lifespan="on",
        timeout_keep_alive=SERVER_KEEP_ALIVE_S,  # one connection for a whole attempt, think time included
    )
    anyio.run(uvicorn.Server(config).serve, backend_options=event_loop_options())
