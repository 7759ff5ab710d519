"""One driver per robot: the lease that keeps a second client from moving the robot mid-task.

A single-robot server has one world, one scratchpad and one episode. Two clients acting on it at
once corrupt each other's tasks (one moves the robot away, the other's end_task counts both), so the
first client that *acts* holds the robot; another gets a tool error for every call that changes
anything (actions, end_task, the scratchpad, the eval profile's controls) until the holder lets go.
Read-only tools and resources stay open to everyone: watching the robot is harmless.

Who a client is depends on how it is connected:

- over stdio, or an in-process or HTTP client with the initialize handshake (protocol 2025-11-25 and
  earlier), its connection (an HTTP session): the lease ends when the connection closes, when an
  HTTP client deletes its session, or when the server closes an idle session (`--session-idle-s`);
- a client without a session (protocol 2026-07-28 and later sends every request on its own) names
  itself with `_meta["robocog/driver"]` on every call (robocog's own client uses the handshake over
  HTTP, so it has a session); one that does not is known by its declared name and version. Such a
  lease ends `idle_s` after its last call.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

from mcp.server.connection import Connection
from mcp.server.context import ServerRequestContext
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from robocog.server.clients import connection_of
from robocog.server.config import DEFAULT_SESSION_IDLE_S
from robocog.shared.protocol import DRIVER_META_KEY


class RobotBusy(Exception):
    """The robot is held by another driver; the message says by whom and what to do."""


@dataclass(frozen=True)
class Driver:
    """A client that wants to act: its identity (`key`), a name for messages, and its connection
    when the lease can end with it."""

    key: Hashable
    label: str
    connection: Connection | None

    @classmethod
    def of(cls, ctx: ServerRequestContext[Any, Any]) -> Driver:
        connection = connection_of(ctx)
        params = connection.client_params
        client = f"{params.client_info.name} {params.client_info.version}" if params is not None else "a client"
        if connection.session_id is not None:  # an HTTP session
            return cls(("session", connection.session_id), f"{client} (HTTP session)", connection)
        if ctx.protocol_version not in MODERN_PROTOCOL_VERSIONS:  # stdio or in-process: the connection
            return cls(("connection", id(connection)), client, connection)
        named = (ctx.meta or {}).get(DRIVER_META_KEY)
        if isinstance(named, str) and named:
            return cls(("driver", named[:200]), f"{client} (driver {named[:40]!r})", None)
        return cls(("client", client), client, None)


class RobotLease:
    """Who holds the robot. Not thread-safe: the app calls it from its event loop only."""

    def __init__(self, *, idle_s: float = DEFAULT_SESSION_IDLE_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.idle_s = idle_s
        self._clock = clock
        self._holder: Driver | None = None
        self._last = 0.0

    @property
    def holder(self) -> Driver | None:
        if self._holder is not None and self._holder.connection is None and self._expired():
            self._holder = None
        return self._holder

    def claim(self, driver: Driver) -> None:
        """Take the robot for `driver`, or raise `RobotBusy` if another holds it."""
        holder = self.holder
        if holder is None:
            self._holder = driver
            if driver.connection is not None:
                driver.connection.exit_stack.callback(self.release, driver.key)
        elif holder.key != driver.key:
            if holder.connection is None:
                left = self.idle_s - (self._clock() - self._last)
                wait = f"it lets go {self.idle_s:g} s after its last call, in {left:.0f} s"
            else:
                wait = "it lets go when that client disconnects or its session idles out"
            raise RobotBusy(
                f"The robot is driven by another session ({holder.label}); {wait}. Read-only tools and "
                "resources still work meanwhile. For a robot per session, start the server as a fleet (--robots N)."
            )
        self._last = self._clock()

    def release(self, key: Hashable) -> None:
        if self._holder is not None and self._holder.key == key:
            self._holder = None

    def _expired(self) -> bool:
        return self._clock() - self._last > self.idle_s
