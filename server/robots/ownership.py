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
  own, and the SDK's default `mcp.Client(url)` speaks it) holds a *robot handle* if it wants one
  (SEP-2567: state that spans calls is a handle the server mints and the client passes as an
  ordinary tool argument). A handle, `robot_id`, is signed by the server (HMAC with a secret of the
  server, shared by a router's fleet processes), so a client cannot make one up or guess another's,
  and messages never show a whole one; one the server did not mint is refused with a tool error.
  The rules (docs/security.md, "Who drives the robot"):
  - one robot: a call with a valid `robot_id` drives as that handle; a call without one is the
    *anonymous driver* (a desktop's one user), so a plain client needs no handle at all. The call
    with which the anonymous driver takes the free robot, and `reset_world`, mint a handle and
    return it (`robot_id` in the result); a handle holds the robot only from the first call that
    presents it, and takes it over from the anonymous driver then. While a handle holds the robot,
    calls without one may read but not act (refused in one line);
  - a fleet: an id-less read-only robot call (`look_around`) or `reset_world` mints a handle and
    binds a free robot to it; an id-less call that acts is refused in one line naming `robot_id`,
    and takes no robot. A robot bound to a handle that was never presented goes back to the pool
    after `UNCONFIRMED_IDLE_S`, or at once when the fleet has no other robot for a new driver;
  - a handle's lease ends `idle_s` after its last call, the anonymous driver's `UNCONFIRMED_IDLE_S`
    after it (anyone without a handle is that driver: it cannot keep the robot from others for long).
  robocog's own client may pass the handle in `_meta["robocog/driver"]` instead (an alias).
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Hashable
from dataclasses import dataclass, replace
from typing import Any

from mcp.server.connection import Connection
from mcp.server.context import ServerRequestContext
from mcp.server.mcpserver.exceptions import ToolError
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from robocog.server import compat
from robocog.server.clients import connection_of
from robocog.server.config import DEFAULT_SESSION_IDLE_S, UNCONFIRMED_IDLE_S
from robocog.server.robots.handles import DriverIds, fingerprint
from robocog.shared.protocol import DRIVER_META_KEY


class RobotBusy(Exception):
    """The robot is held by another driver; the message says by whom and what to do."""


class UnknownDriver(ToolError):
    """`_meta["robocog/driver"]` holds something this server never issued."""


#: What every message that asks for a handle says about how to get one.
HOW_TO_GET_A_HANDLE = "call look_around (or reset_world) without robot_id: its result's robot_id is your robot's handle"


@dataclass(frozen=True)
class Driver:
    """A client that wants to act: its identity (`key`), a name for messages, its connection when
    the lease can end with it, and (sessionless) the handle it drives by (`driver_id`), whether
    the server minted that handle on this very call (`issued_now`: the client has not presented it
    yet), and `minted`, a handle this call returns to its caller (None: none)."""

    key: Hashable
    label: str
    connection: Connection | None
    driver_id: str | None = None
    issued_now: bool = False
    #: A sessionless client that presented no handle (one robot: the anonymous driver).
    anonymous: bool = False
    minted: str | None = None

    def with_new_handle(self, ids: DriverIds) -> Driver:
        """This id-less caller as the holder of a handle minted for it now (a fleet binds a robot to it)."""
        new = ids.issue()
        return Driver(("driver", new), f"robot {fingerprint(new)}", None, new, issued_now=True, minted=new)

    def minting(self, ids: DriverIds) -> Driver:
        """This caller, with a new handle to return to it (it keeps driving as it is until it presents it)."""
        return replace(self, minted=ids.issue())

    @classmethod
    def of(cls, ctx: ServerRequestContext[Any, Any], ids: DriverIds, *, handle: object = None) -> Driver:
        """The driver making request `ctx`; `handle` is the call's `robot_id` argument, if any (else
        the `_meta` alias counts). A sessionless client without a handle is the anonymous driver; a
        handle this server never minted is refused."""
        connection = connection_of(ctx)
        params = connection.client_params
        client = f"{params.client_info.name} {params.client_info.version}" if params is not None else "a client"
        if connection.session_id is not None:  # an HTTP session
            return cls(("session", connection.session_id), f"{client} (HTTP session)", connection)
        if ctx.protocol_version not in MODERN_PROTOCOL_VERSIONS:  # stdio or in-process: the connection
            return cls(("connection", id(connection)), client, connection)
        if connection.has_standalone_channel:  # 2026-07-28 over one duplex stream (stdio)
            return cls(("stream", connection.outbound), client, None)
        handle = None if handle == "" else handle  # an empty robot_id is none
        named = handle if handle is not None else (ctx.meta or {}).get(DRIVER_META_KEY)
        if compat.transport_kind(ctx.session) == "direct":  # the SDK's in-process client: same process, same trust
            if isinstance(named, str) and named:
                return cls(("named", named[:200]), f"{client} (driver {named[:40]!r})", None)
            return cls(("client", client), client, None)
        if named is not None:
            if not isinstance(named, str) or not ids.valid(named):
                where = "robot_id" if handle is not None else f'_meta["{DRIVER_META_KEY}"]'
                raise UnknownDriver(
                    f"{where} is not a robot handle this server minted (a server's handles end when it restarts). "
                    "Leave it out: on a one-robot server you then drive without one; on a fleet, "
                    f"{HOW_TO_GET_A_HANDLE}, and pass that on every later call"
                )
            return cls(("driver", named), f"robot {fingerprint(named)}", None, named)
        return cls(ANONYMOUS, "a client without a robot_id", None, anonymous=True)


#: The anonymous driver's key: every sessionless call without a handle on a one-robot server.
ANONYMOUS = ("anonymous",)


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

    def holds(self, driver: Driver | None) -> bool:
        """Whether `driver` holds the robot, or nobody does (a read-only call then counts as the
        episode's: its caller is the one who acts next)."""
        holder = self.holder
        return holder is None or (driver is not None and holder.key == driver.key)

    def claim(self, driver: Driver) -> bool:
        """Take the robot for `driver`, or raise `RobotBusy` if another holds it; whether `driver`
        took it with this call (it was free, or held by the anonymous driver and `driver` presents
        a handle)."""
        refused = self.refusal(driver)
        if refused is not None:
            raise RobotBusy(refused)
        holder = self.holder
        took = holder is None or holder.key != driver.key
        if took:
            self._holder = driver
            if driver.connection is not None:
                driver.connection.exit_stack.callback(self.release, driver.key)
        self._last = self._clock()
        return took

    def refusal(self, driver: Driver) -> str | None:
        """Why `driver` may not act now (one line), or None: the robot is free, its own, or held by the
        anonymous driver while `driver` presents a handle (which takes it over)."""
        holder = self.holder
        if holder is None or holder.key == driver.key or (holder.anonymous and driver.driver_id is not None):
            return None
        if holder.connection is None:
            limit = self._limit(holder)
            left = max(0.0, limit - (self._clock() - self._last))
            wait = f"it lets go {limit:g} s after its last call, in {left:.0f} s"
        else:
            wait = "it lets go when that client disconnects or its session idles out"
        if holder.connection is not None:
            who = f"another session ({holder.label})"
        elif holder.anonymous:
            who = "a client without a robot_id (no session, no handle)"
        elif holder.driver_id is not None:
            who = f"a client that passes robot_id ({holder.label})"
        else:
            who = f"another client ({holder.label})"
        mine = (
            " If that client is you, pass robot_id on every call."
            if driver.anonymous and holder.driver_id is not None
            else " For a robot per client, start the server as a fleet (--robots N)."
        )
        return f"The robot is driven by {who}; {wait}. Read-only tools and resources still work meanwhile.{mine}"

    def release(self, key: Hashable) -> None:
        if self._holder is not None and self._holder.key == key:
            self._holder = None

    def _limit(self, holder: Driver) -> float:
        """How long `holder` keeps the robot after its last call: the anonymous driver, which any
        client without a handle is, `UNCONFIRMED_IDLE_S` at most; a handle, `idle_s`."""
        return min(self.idle_s, UNCONFIRMED_IDLE_S) if holder.anonymous else self.idle_s

    def _expired(self) -> bool:
        return self._holder is not None and self._clock() - self._last > self._limit(self._holder)


class Presence:
    """What the transport can tell of a session's client: whether it has gone (its event stream
    closed, nothing in flight: `http.VanishedClients`), and a way to close such a session at once.
    A robot held by a client that has gone is given to the next client that asks for it, without
    waiting for the grace in which a client could open its stream again (the MCP Inspector's CLI is
    one process per call, and exits without closing its session). Without a transport that tells
    (stdio, in-process), nobody is ever absent."""

    def __init__(self) -> None:
        self._absent: Callable[[str], bool] | None = None
        self._close: Callable[[str], Awaitable[None]] | None = None

    def attach(self, absent: Callable[[str], bool], close: Callable[[str], Awaitable[None]]) -> None:
        self._absent, self._close = absent, close

    def absent(self, driver: Driver) -> bool:
        sid = _session_id(driver)
        return sid is not None and self._absent is not None and self._absent(sid)

    async def let_go(self, driver: Driver) -> None:
        """Close the session of `driver`, which has gone (its robot's lease ends with it)."""
        sid = _session_id(driver)
        if sid is not None and self._close is not None:
            await self._close(sid)


def _session_id(driver: Driver) -> str | None:
    key = driver.key
    if isinstance(key, tuple) and len(key) == 2 and key[0] == "session" and isinstance(key[1], str):
        return key[1]
    return None
