"""One driver per robot: the lease that keeps a second client from moving the robot mid-task.

A single-robot server has one world, one scratchpad and one episode. Two clients acting on it at
once corrupt each other's tasks (one moves the robot away, the other's end_task counts both), so the
first client that *acts* holds the robot; another gets a tool error for every call that changes
anything (actions, end_task, the scratchpad, the eval profile's controls) until the holder lets go.
Read-only tools and resources stay open to everyone: watching the robot is harmless (and a
watcher's calls are not counted as the driver's episode's tool calls).

Who a client is depends on how it is connected, and is never what it says its name is:

- over stdio, or an in-process or HTTP client with the initialize handshake (protocol 2025-11-25 and
  earlier), its connection (an HTTP session): the lease ends when the connection closes, when an
  HTTP client deletes its session, or when the server closes an idle session (`--session-idle-s`);
- a client on protocol 2026-07-28 and later over one stream (stdio) is that stream; the SDK's
  in-process client (`mcp.Client(server)`, tests in the same process) names itself with
  `_meta["robocog/driver"]`, or is known by its declared name and version;
- a client without a session over HTTP (protocol 2026-07-28 and later sends every request on its
  own, and the SDK's default `mcp.Client(url)` speaks it) is the *driver id the server issued it*:
  the first call that needs a robot and carries no id gets a new one, in the result's
  `_meta["robocog/driver"]`, and the client sends it back in `_meta["robocog/driver"]` on its later
  calls. An id is signed by the server (HMAC with a secret of
  the server, shared by a router's fleet processes), so a client cannot make one up or guess
  another's, and messages never show a whole id. An id the server did not issue is refused with a
  tool error. Such a lease ends `idle_s` after the driver's last call, or `UNCONFIRMED_IDLE_S` after
  it when the client never sent its id back (a client that ignores the id cannot keep the robot).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

from mcp.server.connection import Connection
from mcp.server.context import ServerRequestContext
from mcp.server.mcpserver.exceptions import ToolError
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from robocog.server.clients import connection_of
from robocog.server.config import DEFAULT_SESSION_IDLE_S, DRIVER_SECRET_ENV
from robocog.shared.protocol import DRIVER_META_KEY

#: The environment variable that gives a server its id-signing secret (a router gives its fleet
#: processes one, so an id issued by one is valid in all); without it, a random one per process.
SECRET_ENV = DRIVER_SECRET_ENV
#: How long a driver that never sent its issued id back keeps its robot after its last call.
UNCONFIRMED_IDLE_S = 30.0


class RobotBusy(Exception):
    """The robot is held by another driver; the message says by whom and what to do."""


class UnknownDriver(ToolError):
    """`_meta["robocog/driver"]` holds something this server never issued."""


class DriverIds:
    """Issues and checks driver ids: `ORIGIN.TOKEN.MAC`, where ORIGIN names the fleet process that
    issued it (a router sends the id's later calls there), TOKEN is random and MAC signs both."""

    def __init__(self, secret: bytes | None = None, origin: str = "0") -> None:
        if secret is None:
            shared = os.environ.get(SECRET_ENV)
            secret = shared.encode() if shared else secrets.token_bytes(32)
        self._secret = secret
        self.origin = origin

    def _mac(self, body: str) -> str:
        return hmac.new(self._secret, body.encode(), hashlib.sha256).hexdigest()[:32]

    def issue(self) -> str:
        body = f"{self.origin}.{secrets.token_urlsafe(18)}"
        return f"{body}.{self._mac(body)}"

    def valid(self, value: object) -> bool:
        if not isinstance(value, str) or len(value) > 200 or value.count(".") != 2:
            return False
        body, _, mac = value.rpartition(".")
        return hmac.compare_digest(mac, self._mac(body))


def fingerprint(driver_id: str) -> str:
    """What messages show of an id: enough to tell two apart, not enough to use one."""
    return hashlib.sha256(driver_id.encode()).hexdigest()[:8]


@dataclass(frozen=True)
class Driver:
    """A client that wants to act: its identity (`key`), a name for messages, its connection when
    the lease can end with it, and (sessionless) the id the server issued it and whether it was
    issued by this very call (the client has not sent it back yet)."""

    key: Hashable
    label: str
    connection: Connection | None
    driver_id: str | None = None
    issued_now: bool = False

    @classmethod
    def of(cls, ctx: ServerRequestContext[Any, Any], ids: DriverIds, *, issue: bool = True) -> Driver | None:
        """The driver making request `ctx`. A sessionless client without an id gets a new one when
        `issue` (a call that needs a robot), else None; an id this server never issued is refused."""
        connection = connection_of(ctx)
        params = connection.client_params
        client = f"{params.client_info.name} {params.client_info.version}" if params is not None else "a client"
        if connection.session_id is not None:  # an HTTP session
            return cls(("session", connection.session_id), f"{client} (HTTP session)", connection)
        if ctx.protocol_version not in MODERN_PROTOCOL_VERSIONS:  # stdio or in-process: the connection
            return cls(("connection", id(connection)), client, connection)
        if connection.has_standalone_channel:  # 2026-07-28 over one duplex stream (stdio)
            return cls(("stream", connection.outbound), client, None)
        named = (ctx.meta or {}).get(DRIVER_META_KEY)
        if _transport_kind(ctx) == "direct":  # the SDK's in-process client: same process, same trust
            if isinstance(named, str) and named:
                return cls(("named", named[:200]), f"{client} (driver {named[:40]!r})", None)
            return cls(("client", client), client, None)
        if named is not None:
            if not isinstance(named, str) or not ids.valid(named):
                raise UnknownDriver(
                    f'_meta["{DRIVER_META_KEY}"] is not a driver id this server issued; leave it out of your '
                    "first call that needs a robot, and send back the id that call returns in its result's "
                    f'_meta["{DRIVER_META_KEY}"] on every later call'
                )
            return cls(("driver", named), f"driver {fingerprint(named)}", None, named)
        if not issue:
            return None
        new = ids.issue()
        return cls(("driver", new), f"driver {fingerprint(new)}", None, new, issued_now=True)


def _transport_kind(ctx: ServerRequestContext[Any, Any]) -> str | None:
    """The SDK's name of the transport a request came on ("streamable-http", "jsonrpc", "direct" for
    its in-process client); mcp 2.3 keeps it on the request's dispatch context."""
    transport = getattr(getattr(ctx.session, "_request_outbound", None), "transport", None)
    kind = getattr(transport, "kind", None)
    return kind if isinstance(kind, str) else None


class RobotLease:
    """Who holds the robot. Not thread-safe: the app calls it from its event loop only."""

    def __init__(self, *, idle_s: float = DEFAULT_SESSION_IDLE_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.idle_s = idle_s
        self._clock = clock
        self._holder: Driver | None = None
        self._confirmed = False
        self._last = 0.0

    @property
    def holder(self) -> Driver | None:
        if self._holder is not None and self._holder.connection is None and self._expired():
            self._holder = None
        return self._holder

    def holds(self, driver: Driver | None) -> bool:
        """Whether `driver` holds the robot, or nobody does (a read-only call then counts as the
        episode's: its caller is the one who acts next)."""
        holder = self.holder
        return holder is None or (driver is not None and holder.key == driver.key)

    def claim(self, driver: Driver) -> None:
        """Take the robot for `driver`, or raise `RobotBusy` if another holds it."""
        holder = self.holder
        if holder is None:
            self._holder = driver
            self._confirmed = not driver.issued_now
            if driver.connection is not None:
                driver.connection.exit_stack.callback(self.release, driver.key)
        elif holder.key != driver.key:
            if holder.connection is None:
                left = self._idle_limit() - (self._clock() - self._last)
                wait = f"it lets go {self._idle_limit():g} s after its last call, in {left:.0f} s"
            else:
                wait = "it lets go when that client disconnects or its session idles out"
            mine = (
                f' If that is you, send the id your first call returned in its result\'s _meta["{DRIVER_META_KEY}"] '
                "on every call."
                if holder.driver_id is not None and driver.issued_now
                else ""
            )
            raise RobotBusy(
                f"The robot is driven by another session ({holder.label}); {wait}. Read-only tools and "
                "resources still work meanwhile. For a robot per session, start the server as a fleet (--robots N)."
                + mine
            )
        elif not driver.issued_now:
            self._confirmed = True
        self._last = self._clock()

    def release(self, key: Hashable) -> None:
        if self._holder is not None and self._holder.key == key:
            self._holder = None

    def _idle_limit(self) -> float:
        return self.idle_s if self._confirmed else min(self.idle_s, UNCONFIRMED_IDLE_S)

    def _expired(self) -> bool:
        return self._clock() - self._last > self._idle_limit()
