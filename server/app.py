"""The MCP surface: the robot's tools, its resources and prompts, on mcp 2.x's `MCPServer`.

This module only wires: what each tool does lives in its module under `robocog.server.tools`, and
every tool is registered the same way from the lists there. A server is one robot, or a fleet of
them with one per driver (`fleet.py`). Calls on a robot are serialised (its lock, and the work runs
on a worker thread) so its PyBullet client has one driver at a time, and an action runs to its end
even when the call is cancelled, so the world is always left consistent. One client at a time may
change anything on a robot (the lease, `ownership.py`); with `--confirm-actions` the user allows
each action first (`consent.py`). HTTP's own limits (the bearer token, Host/Origin, sessions) are
in `http.py`.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterable
from contextlib import asynccontextmanager
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import anyio
import anyio.from_thread
import anyio.to_thread
from mcp.server.context import ServerRequestContext
from mcp.server.lowlevel.helper_types import ReadResourceContents
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ResourceError, ToolError, UnexpectedResourceError
from mcp.shared.exceptions import MCPError
from mcp_types import (
    INVALID_PARAMS,
    CallToolResult,
    EmptyResult,
    GetPromptResult,
    InputRequiredResult,
    SetLevelRequestParams,
    SubscribeRequestParams,
    UnsubscribeRequestParams,
)
from pydantic import ValidationError

from robocog.server import compat
from robocog.server.clients import (
    collecting,
    install_log_handlers,
)
from robocog.server.config import AccessConfig, SessionConfig
from robocog.server.events import EventBus
from robocog.server.robots.consent import ConsentGate
from robocog.server.robots.fleet import DEFAULT_OPEN_NAMESPACES, Fleet
from robocog.server.robots.ownership import Presence
from robocog.server.state import REQUEST, AppState
from robocog.server.tools import APP_TOOLS, CONTROL_TOOLS, ROBOT_TOOLS
from robocog.server.wiring.resources import Current, register_completions, register_prompts, register_resources
from robocog.server.wiring.tool_wiring import Access, invalid_arguments, register_tool
from robocog.server.wiring.ui import register_app, tool_meta
from robocog.shared import __version__
from robocog.shared.errors import ConfigError
from robocog.shared.protocol import CONTRACT_VERSION, DRIVER_META_KEY
from robocog.shared.provenance import physics_build

if TYPE_CHECKING:
    pass

Profile = Literal["default", "eval"]
logger = logging.getLogger("robocog.server")
T = TypeVar("T")

INSTRUCTIONS = (
    "A simulated household robot (PyBullet): a mobile manipulator in a kitchen, hallway and living room. "
    "Drive it with look_around, move_to, grab and place; think on the scratchpad; search episodic memory "
    "for past experiences; finish every task with end_task. The robot_system prompt explains the method. "
    f"robocog MCP contract {CONTRACT_VERSION}. Physics: {physics_build()}."
)


class RobocogServer(MCPServer[AppState]):
    """MCPServer, with argument errors a model can read: "Invalid arguments for move_to: location:
    Input should be a valid string (got 5)." instead of pydantic's report (its model name, its
    documentation URL, and up to 200 characters of what was sent back again); and `presence`, what
    its transport tells of its clients (`ownership.Presence`: the HTTP app attaches to it)."""

    presence: Presence

    async def call_tool(
        self, name: str, arguments: dict[str, Any], context: Context[AppState, Any] | None = None
    ) -> CallToolResult | InputRequiredResult:
        try:
            return await super().call_tool(name, arguments, context)
        except ToolError as exc:
            if not isinstance(exc.__cause__, ValidationError):
                raise
            raise ToolError(invalid_arguments(name, exc.__cause__)) from exc.__cause__

    async def get_prompt(
        self, name: str, arguments: dict[str, Any] | None = None, context: Context[AppState, Any] | None = None
    ) -> GetPromptResult | InputRequiredResult:
        """A prompt; wrong arguments (missing, unexpected) are the caller's mistake, answered in one line as
        invalid params, not an internal error whose traceback the log repeats on every call."""
        try:
            return await super().get_prompt(name, arguments, context)
        except ValueError as exc:
            raise MCPError(INVALID_PARAMS, await self._prompt_problem(name, arguments or {}, exc)) from None

    async def _prompt_problem(self, name: str, arguments: dict[str, Any], exc: ValueError) -> str:
        prompt = next((p for p in await self.list_prompts() if p.name == name), None)
        if prompt is None:
            return f"unknown prompt {name!r}; the prompts are: {', '.join(p.name for p in await self.list_prompts())}"
        takes = [a.name for a in prompt.arguments or []]
        needed = [a.name for a in prompt.arguments or [] if a.required]
        unexpected = sorted(set(arguments) - set(takes))
        missing = [a for a in needed if a not in arguments]
        what = f"takes {', '.join(takes)}" if takes else "takes no arguments"
        if unexpected or missing:
            got = "; ".join(
                part
                for part in (
                    f"unexpected: {', '.join(unexpected)}" if unexpected else "",
                    f"missing: {', '.join(missing)}" if missing else "",
                )
                if part
            )
            return f"prompt {name!r} {what} ({got})"
        return f"prompt {name!r}: {' '.join(str(exc).split())[:300]}"

    async def read_resource(
        self, uri: Any, context: Context[AppState, Any] | None = None
    ) -> Iterable[ReadResourceContents] | InputRequiredResult:
        """Resources read the caller's robot: the request is remembered for them (see `REQUEST`)."""
        token = REQUEST.set(None if context is None else context.request_context)
        try:
            return await super().read_resource(uri, context)
        except UnexpectedResourceError as exc:
            if isinstance(exc.__cause__, ToolError):  # ours, written for the client (no robot, no id)
                raise ResourceError(str(exc.__cause__)) from exc.__cause__
            raise
        finally:
            REQUEST.reset(token)


def register_logging_and_subscriptions(mcp: MCPServer[AppState]) -> None:
    """`logging/setLevel`, `resources/subscribe` and `resources/unsubscribe` (see `clients.py`).
    MCPServer has no decorator for these, so they go to its low-level server."""

    async def set_level(ctx: ServerRequestContext[AppState], params: SetLevelRequestParams) -> EmptyResult:
        await ctx.lifespan_context.clients.set_level(ctx, params.level)
        return EmptyResult()

    async def subscribe(ctx: ServerRequestContext[AppState], params: SubscribeRequestParams) -> EmptyResult:
        ctx.lifespan_context.clients.subscribe(ctx, str(params.uri))
        return EmptyResult()

    async def unsubscribe(ctx: ServerRequestContext[AppState], params: UnsubscribeRequestParams) -> EmptyResult:
        ctx.lifespan_context.clients.unsubscribe(ctx, str(params.uri))
        return EmptyResult()

    lowlevel = compat.lowlevel(mcp)
    lowlevel.add_request_handler("logging/setLevel", SetLevelRequestParams, set_level)
    lowlevel.add_request_handler("resources/subscribe", SubscribeRequestParams, subscribe)
    lowlevel.add_request_handler("resources/unsubscribe", UnsubscribeRequestParams, unsubscribe)


#: The identity rules, published as an experimental capability so that the contract (and `robocog
#: contract check`) sees them: over HTTP without a session, a driver is the handle the server minted
#: (`issued`), passed as the tools' `robot_id` argument (`handle`; SEP-2567).
DRIVER_RULE = {"issued": True, "handle": True}


def publish_driver_rule(mcp: MCPServer[AppState]) -> None:
    """Declare `experimental["robocog/driver"]` in the server's capabilities, on every protocol
    generation (the SDK builds them in more than one place, all through `get_capabilities`)."""
    lowlevel = compat.lowlevel(mcp)
    original = lowlevel.get_capabilities

    def get_capabilities(*args: Any, **kwargs: Any) -> Any:
        capabilities = original(*args, **kwargs)
        experimental = {**(capabilities.experimental or {}), DRIVER_META_KEY: DRIVER_RULE}
        return capabilities.model_copy(update={"experimental": experimental})

    lowlevel.get_capabilities = get_capabilities  # type: ignore[method-assign]


async def optional(what: str, run: Callable[[], Awaitable[None]]) -> None:
    """Run an optional part of the server (the live viewer); if it fails, say so in one line and let
    the MCP server carry on without it: nothing optional takes the robot down."""
    try:
        await run()
    except Exception as exc:
        why = f"{type(exc).__name__}: {exc}"
        print(f"robocog-server: {what} stopped ({why}); the MCP server carries on", file=sys.stderr)


def _auth(access: AccessConfig) -> dict[str, Any]:
    """The SDK's auth arguments for a bearer token (none without one)."""
    if access.auth_token is None:
        return {}
    from robocog.server.transport.http import BearerToken, auth_settings

    return {"auth": auth_settings(access.url), "token_verifier": BearerToken(access.auth_token)}


def trace_only_when_traced(mcp: MCPServer[Any]) -> None:
    """Take the SDK's OpenTelemetry middleware off `mcp` when nothing records spans: it opens a span
    for every message (attributes, context extraction, about 0.1 ms a call), a no-op without a tracer
    provider. A provider installed before the server is built (as `opentelemetry-instrument` does, or
    `OTEL_PYTHON_TRACER_PROVIDER`) keeps it, and every call is a span as before."""
    from opentelemetry import trace

    middleware = compat.otel_middleware()

    provider = trace.get_tracer_provider()
    if isinstance(provider, trace.ProxyTracerProvider | trace.NoOpTracerProvider):
        mcp.middleware[:] = [m for m in mcp.middleware if not isinstance(m, middleware)]


def build_server(
    config: SessionConfig | None = None,
    *,
    profile: Profile = "default",
    log_level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = "WARNING",
    access: AccessConfig | None = None,
    view: int | None = None,
    robots: int = 1,
    per_driver: bool | None = None,
    open_namespaces: int = DEFAULT_OPEN_NAMESPACES,
    app: bool = True,
) -> MCPServer[AppState]:
    """The robocog MCP server for `config`; the `eval` profile adds the harness controls; `access`
    sets the bearer token, the consent gate, the published tools and the lease; `view`, a port,
    serves the live viewer there (127.0.0.1; 0 picks a free port) from this process; `robots` > 1
    makes it a fleet: each driver (an HTTP session, a connection) gets a robot of its own (as with
    `per_driver`, for one robot too: a fleet's process behind a router). Every tool takes the optional
    `robot_id` (a robot handle, for clients without a session: `ownership.py`), on every transport, so
    that the contract is one; clients never offer it to a model (`shared.provenance.function_definition`).
    `app` publishes the robot app (`ui.py`: its page, the robot tools' links to it, its own tool)."""
    config = config or SessionConfig()
    access = access or AccessConfig()
    if robots < 1:
        raise ConfigError(f"--robots: a server has at least one robot, not {robots}")
    if robots > 1 and view is not None:
        raise ConfigError("--view watches one robot: it cannot be combined with a fleet (--robots above 1)")
    if access.allow_tools is not None:
        unknown = access.allow_tools - {t.name for t in ROBOT_TOOLS + APP_TOOLS}
        if unknown:
            known = ", ".join(t.name for t in ROBOT_TOOLS + APP_TOOLS)
            raise ConfigError(f"--allow-tools: no tool called {', '.join(sorted(unknown))}; the tools are {known}")
    current = Current()

    @asynccontextmanager
    async def lifespan(server: MCPServer[AppState]) -> AsyncIterator[AppState]:
        fleet = Fleet(
            config,
            capacity=robots,
            per_driver=per_driver,
            idle_s=access.lease_idle_s,
            open_namespaces=open_namespaces,
        )
        if isinstance(server, RobocogServer) and hasattr(server, "presence"):
            fleet.presence = server.presence
        state = current.state = AppState(fleet)

        async def build() -> None:
            # In the background: the server answers initialize and tools/list meanwhile. Its log
            # records are kept for the clients that set a log level, now or later.
            with collecting(state.clients.keep):
                try:
                    started = time.monotonic()
                    robot = await anyio.to_thread.run_sync(fleet.build)
                    await anyio.to_thread.run_sync(robot.session.warm_up)
                    world = robot.session.world
                    logger.info(
                        "robot ready in %.1f s: scene %r, %d objects, %d locations, profile %s%s",
                        time.monotonic() - started,
                        world.scene.name,
                        len(world.object_names),
                        len(world.map.points),
                        profile,
                        "" if fleet.shared else f", a fleet of up to {robots} robots",
                    )
                except Exception as exc:  # reported to every caller, the server keeps running
                    logger.exception("the robot session could not be built")
                    state.failure = f"{type(exc).__name__}: {exc}"
                finally:
                    state.ready.set()
            await state.clients.send_backlog()

        viewer = None
        if view is not None:
            from robocog.server.viewer import Viewer

            state.events = EventBus()
            viewer = Viewer(state, state.events, view)
        async with anyio.create_task_group() as tg:
            tg.start_soon(build)
            if viewer is not None:
                tg.start_soon(optional, "the live viewer", viewer.run)
            try:
                yield state
            finally:
                if viewer is not None:
                    viewer.stop()
                await state.ready.wait()
                current.state = None
                await anyio.to_thread.run_sync(fleet.close)

    mcp = RobocogServer(
        "robocog",
        title="robocog household robot",
        instructions=INSTRUCTIONS,
        version=__version__,
        lifespan=lifespan,
        log_level=log_level,
        **_auth(access),
    )
    mcp.presence = Presence()
    install_log_handlers(log_level)
    trace_only_when_traced(mcp)
    guard = Access(gate=ConsentGate() if access.confirm_actions else None)
    allowed = [t for t in ROBOT_TOOLS + APP_TOOLS if access.allow_tools is None or t.name in access.allow_tools]
    published = [t for t in allowed if app or t.kind != "app"]
    for tool in published + list(CONTROL_TOOLS if profile == "eval" else ()):
        register_tool(mcp, tool, guard, meta=tool_meta(tool.name, tool.kind) if app else None)
    register_resources(mcp, current)
    if app:
        register_app(mcp)
    register_prompts(mcp)
    register_completions(mcp, current)
    register_logging_and_subscriptions(mcp)
    publish_driver_rule(mcp)
    return mcp
