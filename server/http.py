"""The robot over streamable HTTP: who may connect, how many at once, and for how long.

- **Bind**: loopback by default. Binding to any other address refuses to start without a bearer
  token, so a robot is never exposed to a network unauthenticated.
- **Bearer token** (`--auth-token`, `$ROBOCOG_AUTH_TOKEN`, or `--auth-token generate`): every request
  to /mcp carries `Authorization: Bearer TOKEN`; without it 401, with a wrong one 401. Checked by
  the MCP SDK's own auth middleware through a `TokenVerifier` (`BearerToken` below), compared in
  constant time. TLS is a reverse proxy's job (the README shows one).
- **Host and Origin** are always checked (DNS rebinding): loopback names, the bind address, this
  machine's names, and whatever `--allowed-host`/`--allowed-origin` add; a foreign Host gets 421,
  a foreign Origin 403.
- **Sessions**: at most `--max-sessions` open at once (503 with a message saying so past the cap),
  each closed after `--session-idle-s` without a request, its memory returned.
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

from robocog.server.config import DEFAULT_MAX_SESSIONS, DEFAULT_SESSION_IDLE_S
from robocog.shared.errors import ConfigError
from robocog.shared.web import LOOPBACK_NAMES

# The MCP SDK is imported where it is used: the command line checks its options with this module
# before it pays for the SDK's import (a bad option fails in a fraction of a second).
if TYPE_CHECKING:
    from mcp.server.auth.provider import AccessToken
    from mcp.server.auth.settings import AuthSettings
    from mcp.server.mcpserver import MCPServer
    from mcp.server.transport_security import TransportSecuritySettings
    from starlette.types import ASGIApp, Message, Receive, Scope, Send

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


def build_app(mcp: MCPServer[Any], options: HttpOptions) -> ASGIApp:
    """The Starlette app of `mcp` with robocog's limits and checks."""
    app = mcp.streamable_http_app(
        host=options.host,
        transport_security=options.transport_security(),
        max_sessions=options.max_sessions,
        session_idle_timeout=options.session_idle_s,
    )
    return SessionCapMessage(app, max_sessions=options.max_sessions, idle_s=options.session_idle_s)


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
    )
    anyio.run(uvicorn.Server(config).serve)
