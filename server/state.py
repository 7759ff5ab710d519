"""What a running server holds (`AppState`: its robots, who is connected) and the request being
answered (`REQUEST`): the MCP app (`app.py`), the tool handlers (`tool_wiring.py`), the resources
and the viewer all read it, and it imports none of them."""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import anyio
from mcp.server.context import ServerRequestContext
from mcp.server.mcpserver.exceptions import ToolError

from robocog.server.clients import Clients
from robocog.server.events import EventBus
from robocog.server.memory.episodic import storage_problem
from robocog.server.robots.fleet import Fleet, Robot
from robocog.server.robots.handles import DriverIds
from robocog.server.robots.ownership import HOW_TO_GET_A_HANDLE, Driver
from robocog.shared.errors import WorldError
from robocog.shared.protocol import DRIVER_META_KEY

logger = logging.getLogger("robocog.server")

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

T = TypeVar("T")


#: The request a resource read or a completion is answering: the SDK gives static resources no
#: Context, and a fleet needs the caller to know whose robot to read (set by `app.RobocogServer`).
REQUEST: ContextVar[ServerRequestContext[Any, Any] | None] = ContextVar("robocog_request", default=None)


@dataclass
class AppState:
    """What the lifespan owns: the robots (built in the background: one, or a fleet's first) and
    who is connected."""

    fleet: Fleet
    ready: anyio.Event = field(default_factory=anyio.Event)
    clients: Clients = field(default_factory=Clients)
    failure: str | None = None
    #: The live viewer's events (`robocog-server --view`); None without a viewer.
    events: EventBus | None = None
    #: Issues and checks the driver ids of sessionless clients (`ownership.py`).
    ids: DriverIds = field(default_factory=lambda: DriverIds(origin=fleet_origin()))

    @property
    def session(self) -> RobotSession:
        """The first robot's session (the only one, unless the server is a fleet)."""
        first = self.fleet.first
        if first is None:
            raise ToolError(f"the robot is not available: {self.failure or 'still starting'}")
        return first.session

    async def robot(self, ctx: ServerRequestContext[Any, Any] | None = None, driver: Driver | None = None) -> Robot:
        """The robot of `driver`, or of the client making request `ctx` (default: the request being
        answered; with none, the first robot). On a fleet, a sessionless client that sends no driver
        id has no robot to read (a tool call gives it one, and its id)."""
        await self.ready.wait()
        if self.failure is not None:
            raise ToolError(f"the robot is not available: {self.failure}")
        ctx = ctx or REQUEST.get()
        if ctx is None or self.fleet.shared:
            return await self.fleet.robot_for(None)
        driver = driver or Driver.of(ctx, self.ids)
        if driver.anonymous:
            raise ToolError(
                "this server is a fleet: each client reads its own robot. A client without a session sends its "
                f"robot's handle (a tool's robot_id) in _meta[\"{DRIVER_META_KEY}\"]; to get one, {HOW_TO_GET_A_HANDLE}"
            )
        return await self.fleet.robot_for(driver)

    def refusal(self, driver: Driver, tool: str, *, exclusive: bool) -> str | None:
        """Why a call by `driver` to `tool` is refused before it runs, or None: a fleet's id-less call that
        acts, or a one-robot server held by another driver (whose client has not gone). Asked before the
        user's consent too, so that the user is never asked about a call that cannot happen."""
        if not exclusive:
            return None
        if not self.fleet.shared:
            return needs_handle(tool, self.fleet.capacity) if driver.anonymous and tool != "reset_world" else None
        first = self.fleet.first
        holder = first.lease.holder if first is not None else None
        if first is None or holder is None or self.fleet.presence.absent(holder):
            return None
        return first.lease.refusal(driver)

    async def run(self, fn: Callable[[RobotSession], T], ctx: ServerRequestContext[Any, Any] | None = None) -> T:
        """Run `fn(session)` on the caller's robot (see `robot`), serialised, to completion.

        A `ValueError` (bad input the caller can fix) becomes a tool error with its message.
        """
        return await self.run_on(await self.robot(ctx), fn)

    async def run_on(self, robot: Robot, fn: Callable[[RobotSession], T], *, tool: str | None = None) -> T:
        """Run `fn(session)` on `robot`, serialised, to completion; a `ValueError` (bad input), a
        `WorldError` (an action past its bounds) or the memory's storage failing (`storage_problem`)
        becomes a tool error with its reason, never the SDK's bare "Error executing tool X"."""
        try:
            return await self.fleet.call(robot, fn, tool=tool)
        except (ValueError, WorldError) as exc:
            raise ToolError(str(exc)) from exc
        except Exception as exc:  # the memory's storage failed (a full disk, a read-only database): say why
            problem = storage_problem(exc)
            if problem is None:
                raise
            logger.error("%s", problem)
            raise ToolError(problem) from exc


def fleet_origin() -> str:
    """Which of a router's fleet processes this is (`ROBOCOG_FLEET_PROCESS` "i/n"), as the driver ids
    it issues name it (the router sends an id's calls to the process that issued it); "0" alone."""
    number = os.environ.get("ROBOCOG_FLEET_PROCESS", "1/1").split("/", 1)[0]
    return str(int(number) - 1) if number.isdigit() and int(number) > 0 else "0"


def needs_handle(tool: str, robots: int) -> str:
    """The one line an id-less call that acts gets from a fleet."""
    return (
        f"This server is a fleet of {robots} robots, and {tool} acts on one: pass robot_id, your robot's handle. "
        f"To get one, {HOW_TO_GET_A_HANDLE}; pass it as robot_id on every later call."
    )
