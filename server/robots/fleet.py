"""The robots of one server process: one robot shared by every client, or a fleet of them.

A server with one robot (the default) is what a desktop assistant talks to: every client sees the
same world, and the first that acts holds it (the lease, `ownership.py`). A fleet
(`robocog-server --robots N`) gives each driver its own robot instead (its world, scratchpad and
episode; memory is by namespace, shared: the server's unless a harness picks one) so that a harness
keeps dozens of episodes in flight against one process. A driver is what `ownership.Driver` says
it is: an HTTP session, a connection, or a sessionless client's server-issued driver id; its robot
goes back to the pool when the driver goes (its connection closes, or it is silent for `idle_s`),
and is made as good as new (`RobotSession.recycle`) before the next driver gets it.

The robots share what is heavy and shareable: the embedding model (one per process already), and
one Chroma client and collection handle per memory namespace in use (`Memories`, bounded). Each
robot is its own PyBullet client (about 29 MB a robot, nearly all of it PyBullet's own: docs/figures.md,
Scale; a shared client would make the robots one simulation) and its calls are serialised by its
own lock; different robots' calls run on worker threads side by side (PyBullet holds the GIL while
it steps, so one process uses about one core: a machine's cores are used by a few fleet processes).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

import anyio
import anyio.to_thread
from mcp.server.mcpserver.exceptions import ToolError

from robocog.server.config import DEFAULT_SESSION_IDLE_S, UNCONFIRMED_IDLE_S, SessionConfig
from robocog.server.robots.ownership import Driver, Presence, RobotLease
from robocog.shared.protocol import FLEET_FULL

if TYPE_CHECKING:
    from robocog.server.memory.episodic import EpisodicMemory
    from robocog.server.robots.session import RobotSession

T = TypeVar("T")
logger = logging.getLogger("robocog.server.fleet")


#: Memory namespaces a fleet process keeps open at once (`--memory-namespaces`): past it, the
#: process closes them all between calls and opens again only those used next.
DEFAULT_OPEN_NAMESPACES = 32
#: How long a robot bound to a handle never presented is kept from a new driver when the fleet has no
#: free robot (its client has had time to present it; a burst of new clients does not take each other's).
RECLAIM_AFTER_S = 5.0
#: Uses of the memory (a search, a write, a verdict) after which it is closed and opened again
#: all the same: Chroma's client grows with every search after a write (about 200 KB each) and
#: gives it back only when it stops.
RECYCLE_USES = 200


class Memories:
    """The episodic memory of each namespace in use, opened on first use and shared by every robot
    of the process (one Chroma client; the embedding model is per process anyway).

    Bounded: Chroma keeps every collection a client has touched loaded (about 2.7 MB each), and
    grows with every search after a write (about 200 KB each), and frees it only when its client
    stops; so past `cap` open namespaces, or `RECYCLE_USES` uses, `due` says so and the fleet calls
    `close_all` while no call runs (`Fleet.call`); a robot asks for its memory on each use, so the
    next use opens it again."""

    def __init__(self, config: SessionConfig, *, cap: int = DEFAULT_OPEN_NAMESPACES) -> None:
        self.config = config
        self.cap = cap
        self._open: dict[str, EpisodicMemory] = {}
        self._lock = threading.Lock()
        #: How often every namespace was closed to stay bounded; uses since the last time.
        self.recycled = 0
        self.uses = 0
        self._announced: set[str] = set()

    def __call__(self, namespace: str) -> EpisodicMemory:
        from robocog.server.memory.episodic import EpisodicMemory

        with self._lock:  # robots open memories on worker threads
            self.uses += 1
            memory = self._open.get(namespace)
            if memory is None:
                memory = EpisodicMemory(self.config.data_dir, url=self.config.memory_url, namespace=namespace)
                self._open[namespace] = memory
                if namespace not in self._announced:  # once per namespace, not at every reopening
                    if len(self._announced) > 1000:
                        self._announced.clear()
                    self._announced.add(namespace)
                    where = (
                        f"the Chroma server at {self.config.memory_url}"
                        if self.config.memory_url
                        else "embedded ChromaDB"
                    )
                    logger.info("episodic memory: %s, namespace %r", where, namespace)
            return memory

    def drop(self, namespace: str) -> int:
        """Delete `namespace` and its files (`EpisodicMemory.drop`: the bytes removed), and forget
        its handle."""
        memory = self(namespace)
        with self._lock:
            freed = memory.drop()
            self._open.pop(namespace, None)
            memory.close()
        return freed

    @property
    def due(self) -> bool:
        """Whether to close them all (more than `cap` open, or `RECYCLE_USES` uses since)."""
        return len(self._open) > self.cap or (self.uses >= RECYCLE_USES and bool(self._open))

    def open_namespaces(self) -> int:
        return len(self._open)

    def close_all(self) -> None:
        """Close every namespace (call it while no robot uses one) and stop Chroma's client, which
        returns what it held."""
        from robocog.server.memory.chroma import EMBEDDED

        with self._lock:
            for memory in self._open.values():
                memory.close()
            self._open.clear()
            self.uses = 0
        EMBEDDED.stop_idle()

    def close(self) -> None:
        self.close_all()


@dataclass(eq=False)
class Robot:
    """One robot: its session, the lock that serialises calls on it, and who may act on it."""

    number: int
    session: RobotSession
    lease: RobotLease
    clock: Callable[[], float] = time.monotonic
    #: Taken at once when free (`fast_acquire`): a free robot's call does not first give the event loop
    #: a turn (an iteration of it on every call); a call that waits for it still queues fairly.
    lock: anyio.Lock = field(default_factory=lambda: anyio.Lock(fast_acquire=True))
    #: The driver it is bound to (a fleet's robots; None: free, or a single robot shared by all).
    driver: Driver | None = None
    #: Whether a driver has had it (recycle it before the next one).
    used: bool = False
    last_call: float = 0.0
    #: Whether its sessionless driver has sent its issued id back (else it idles out sooner).
    confirmed: bool = True

    async def run(
        self, fn: Callable[[RobotSession], T], limiter: anyio.CapacityLimiter | None = None, *, tool: str | None = None
    ) -> T:
        """Run `fn(session)` on a worker thread, one call at a time on this robot, to completion
        (a cancelled call still finishes its action: the world is always left consistent). The robot
        is made ready first (`RobotSession.ready`: a recycled robot's world put back), knowing the
        `tool` a call runs (None: a read)."""

        def ready_then(session: RobotSession) -> T:
            session.ready(tool)
            return fn(session)

        async with self.lock:
            self.last_call = self.clock()
            try:
                return await anyio.to_thread.run_sync(
                    ready_then, self.session, abandon_on_cancel=False, limiter=limiter
                )
            finally:
                self.last_call = self.clock()


class FleetFull(ToolError):
    """Every robot of the fleet is driven by someone."""


class Fleet:
    """The server's robots: one robot for everyone, or (`per_driver`, by default when `capacity` is
    above 1) one robot per driver, up to `capacity`."""

    def __init__(
        self,
        config: SessionConfig,
        *,
        capacity: int = 1,
        per_driver: bool | None = None,
        idle_s: float = DEFAULT_SESSION_IDLE_S,
        clock: Callable[[], float] = time.monotonic,
        open_namespaces: int = DEFAULT_OPEN_NAMESPACES,
    ) -> None:
        if capacity < 1:
            raise ValueError(f"a server has at least one robot, not {capacity}")
        self.config = config
        self.capacity = capacity
        #: A robot per driver (a fleet), or one robot for all; a fleet's process behind a router is a
        #: fleet even with one robot.
        self.per_driver = capacity > 1 if per_driver is None else per_driver
        self.idle_s = idle_s
        self._clock = clock
        self.memories = Memories(config, cap=open_namespaces)
        #: Calls running or waiting for their robot, and the gate that holds new ones while the
        #: memories are closed (`call`).
        self._calls = 0
        self._drained = anyio.Event()
        self._gate: anyio.Event | None = None
        self.robots: list[Robot] = []
        self._free: list[Robot] = []
        self._bound: dict[Hashable, Robot] = {}
        self._assigning = anyio.Lock()
        #: What the transport tells of its clients (a session whose client has gone gives up its robot).
        self.presence = Presence()
        # Different robots' calls run side by side: a thread each (anyio's default is 40 in all).
        self.limiter = anyio.CapacityLimiter(max(4, capacity + 2))

    @property
    def shared(self) -> bool:
        """One robot that every client shares (the lease decides who may act)."""
        return not self.per_driver

    @property
    def first(self) -> Robot | None:
        return self.robots[0] if self.robots else None

    def build(self) -> Robot:
        """Build one more robot (on a worker thread: it takes about 0.2 s) and keep it free."""
        from robocog.server.robots.session import RobotSession

        session = RobotSession(self.config, memories=self.memories)
        lease = RobotLease(idle_s=self.idle_s, clock=self._clock)
        robot = Robot(number=len(self.robots) + 1, session=session, lease=lease, clock=self._clock)
        self.robots.append(robot)
        self._free.append(robot)
        return robot

    async def robot_for(self, driver: Driver | None) -> Robot:
        """The robot `driver` drives: the shared one, the one bound to it, or a free one (recycled, or
        built while there are fewer than `capacity`). `driver` None (the live viewer, a resource read
        with no request) gets the first robot. Raises `FleetFull` when every robot is bound."""
        first = self.first
        if first is None:
            raise ToolError("the robot is not available: still starting")
        if self.shared or driver is None:
            return first
        robot = self._bound.get(driver.key)
        if robot is not None:
            robot.confirmed = robot.confirmed or not driver.issued_now
            return robot
        async with self._assigning:
            robot = self._bound.get(driver.key)
            if robot is not None:
                return robot
            self._release_idle()
            if self._free:
                robot = self._free.pop(0)
            elif len(self.robots) < self.capacity:
                robot = await anyio.to_thread.run_sync(self.build, limiter=self.limiter)
                self._free.remove(robot)
            else:
                robot = await self._reclaim()
                if robot is None:
                    raise FleetFull(self.full_message())
            if robot.used:
                try:
                    async with robot.lock:  # a call of its last driver may still be finishing
                        await anyio.to_thread.run_sync(robot.session.recycle, limiter=self.limiter)
                except BaseException:  # cancelled, or the reset failed: the robot stays in the pool
                    self._free.append(robot)
                    raise
            robot.used = True
            robot.driver = driver
            robot.confirmed = not driver.issued_now
            robot.last_call = self._clock()
            self._bound[driver.key] = robot
            if driver.connection is not None:
                driver.connection.exit_stack.callback(self.release, driver.key)
            logger.info("robot %d now driven by %s", robot.number, driver.label)
            return robot

    async def _reclaim(self) -> Robot | None:
        """A robot for a new driver when none is free: one bound to a handle its client never presented,
        `RECLAIM_AFTER_S` after its last call, or to a session whose client has gone (`Presence`), the
        longest quiet first; None if every robot is driven."""
        now = self._clock()
        spare = [
            robot
            for robot in self._bound.values()
            if robot.driver is not None
            and not robot.lock.locked()
            and (
                (robot.driver.connection is None and not robot.confirmed and now - robot.last_call > RECLAIM_AFTER_S)
                or self.presence.absent(robot.driver)
            )
        ]
        if not spare:
            return None
        robot = min(spare, key=lambda r: r.last_call)
        gone = robot.driver
        assert gone is not None
        logger.info("robot %d taken back from %s for a new driver", robot.number, gone.label)
        self.release(gone.key)
        self._free.remove(robot)
        await self.presence.let_go(gone)
        return robot

    def full_message(self) -> str:
        """Why a new driver gets no robot, with the true counts (a router's process says whose)."""
        advice = (
            "close a session or stop using a handle, wait for one to idle out (a robot whose handle was never "
            f"presented is free again within {RECLAIM_AFTER_S:g} s), or start the server with more robots"
        )
        routed = os.environ.get("ROBOCOG_FLEET_PROCESS", "")
        number, _, processes = routed.partition("/")
        total = os.environ.get("ROBOCOG_FLEET_ROBOTS", "")
        if processes.isdigit() and int(processes) > 1 and total.isdigit():
            return (
                f"fleet process {number} of {processes}: all {self.capacity} {FLEET_FULL}, and the router sends a new "
                f"client to a process with a free robot first, so all {total} of the server's are driven (--robots "
                f"{total}); " + advice
            )
        return f"all {self.capacity} {FLEET_FULL} (--robots {self.capacity}); " + advice

    async def call(self, robot: Robot, fn: Callable[[RobotSession], T], *, tool: str | None = None) -> T:
        """Run `fn` on `robot` (see `Robot.run`); afterwards, if the memories are due to be closed
        (`Memories.due`), hold new calls, let the running ones finish, and close them all."""
        while self._gate is not None:
            await self._gate.wait()
        self._calls += 1
        try:
            return await robot.run(fn, self.limiter, tool=tool)
        finally:
            self._calls -= 1
            if self._calls == 0:
                self._drained.set()
            if self.memories.due and self._gate is None:
                await self._close_memories()

    async def _close_memories(self) -> None:
        gate = self._gate = anyio.Event()
        try:
            with anyio.CancelScope(shield=True):
                while self._calls:
                    self._drained = anyio.Event()
                    await self._drained.wait()
                opened = self.memories.open_namespaces()
                await anyio.to_thread.run_sync(self.memories.close_all, limiter=self.limiter)
                self.memories.recycled += 1
                logger.info("closed the memory (%d namespaces open) to keep it bounded", opened)
        finally:
            self._gate = None
            gate.set()

    def release(self, key: Hashable) -> None:
        """The driver `key` has gone: its robot is free again (recycled before its next driver)."""
        robot = self._bound.pop(key, None)
        if robot is not None:
            robot.driver = None
            robot.lease.release(key)
            self._free.append(robot)
            logger.info("robot %d is free", robot.number)

    def _release_idle(self) -> None:
        """Free the robots of drivers without a connection (they send their issued id on each call)
        that have been silent for `idle_s`, or `UNCONFIRMED_IDLE_S` if they never sent it back."""
        now = self._clock()
        for key, robot in list(self._bound.items()):
            sessionless = robot.driver is not None and robot.driver.connection is None
            limit = self.idle_s if robot.confirmed else min(self.idle_s, UNCONFIRMED_IDLE_S)
            if sessionless and now - robot.last_call > limit and not robot.lock.locked():
                self.release(key)

    def in_use(self) -> int:
        return len(self._bound)

    def close(self) -> None:
        for robot in self.robots:
            robot.session.close()
        self.memories.close()
