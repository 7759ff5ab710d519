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

import base64
import inspect
import json
import logging
import time
from collections.abc import AsyncIterator, Callable, Iterable
from contextlib import asynccontextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeVar

import anyio
import anyio.from_thread
import anyio.to_thread
from mcp.server.context import ServerRequestContext
from mcp.server.lowlevel.helper_types import ReadResourceContents
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ResourceError, ToolError, UnexpectedResourceError
from mcp_types import (
    CallToolResult,
    EmptyResult,
    ImageContent,
    InputRequiredResult,
    SetLevelRequestParams,
    SubscribeRequestParams,
    TextContent,
    UnsubscribeRequestParams,
)
from pydantic import BaseModel, ValidationError

from robocog.server.clients import (
    WORLD_RESOURCES,
    Clients,
    LogEntry,
    collecting,
    connection_of,
    install_log_handlers,
)
from robocog.server.config import AccessConfig, SessionConfig
from robocog.server.consent import ConsentGate
from robocog.server.events import EventBus
from robocog.server.fleet import DEFAULT_OPEN_NAMESPACES, Fleet, Robot
from robocog.server.ownership import Driver, DriverIds, RobotBusy
from robocog.server.resources import Current, register_completions, register_prompts, register_resources
from robocog.server.tools import CONTROL_TOOLS, ROBOT_TOOLS
from robocog.server.tools.base import Caller, ProgressFn, Tool
from robocog.shared import __version__
from robocog.shared.errors import ConfigError
from robocog.shared.protocol import CONTRACT_VERSION, DRIVER_META_KEY, MODEL_META_KEY
from robocog.shared.results import WithImage

if TYPE_CHECKING:
    from robocog.server.session import RobotSession

Profile = Literal["default", "eval"]
logger = logging.getLogger("robocog.server")
T = TypeVar("T")

INSTRUCTIONS = (
    "A simulated household robot (PyBullet): a mobile manipulator in a kitchen, hallway and living room. "
    "Drive it with look_around, move_to, grab and place; think on the scratchpad; search episodic memory "
    "for past experiences; finish every task with end_task. The robot_system prompt explains the method. "
    f"robocog MCP contract {CONTRACT_VERSION}."
)


#: The request a resource read or a completion is answering: the SDK gives static resources no
#: Context, and a fleet needs the caller to know whose robot to read (set by `RobocogServer`).
_REQUEST: ContextVar[ServerRequestContext[Any, Any] | None] = ContextVar("robocog_request", default=None)


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
    ids: DriverIds = field(default_factory=lambda: DriverIds(origin=_fleet_origin()))

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
        ctx = ctx or _REQUEST.get()
        if ctx is None or self.fleet.shared:
            return await self.fleet.robot_for(None)
        driver = driver or Driver.of(ctx, self.ids, issue=False)
        if driver is None:
            raise ToolError(
                "this server is a fleet: each driver reads its own robot. A client without a session sends, in "
                f'_meta["{DRIVER_META_KEY}"], the driver id its first tool call returned in its result\'s _meta'
            )
        return await self.fleet.robot_for(driver)

    async def run(self, fn: Callable[[RobotSession], T], ctx: ServerRequestContext[Any, Any] | None = None) -> T:
        """Run `fn(session)` on the caller's robot (see `robot`), serialised, to completion.

        A `ValueError` (bad input the caller can fix) becomes a tool error with its message.
        """
        return await self.run_on(await self.robot(ctx), fn)

    async def run_on(self, robot: Robot, fn: Callable[[RobotSession], T]) -> T:
        """Run `fn(session)` on `robot`, serialised, to completion; a `ValueError` becomes a tool error."""
        try:
            return await self.fleet.call(robot, fn)
        except ValueError as exc:
            raise ToolError(str(exc)) from exc


def _fleet_origin() -> str:
    """Which of a router's fleet processes this is (`ROBOCOG_FLEET_PROCESS` "i/n"), as the driver ids
    it issues name it (the router sends an id's calls to the process that issued it); "0" alone."""
    import os

    number = os.environ.get("ROBOCOG_FLEET_PROCESS", "1/1").split("/", 1)[0]
    return str(int(number) - 1) if number.isdigit() and int(number) > 0 else "0"


def _tool_result(result: BaseModel) -> CallToolResult:
    """Structured content plus the same JSON as text; a failed action is marked as a tool error. A
    result with a picture attached (`WithImage`, e.g. look's) also gets it as an image content block
    after the text: the JSON only describes it (`image`: type and size), never carries the bytes."""
    data = result.model_dump(mode="json")
    content: list[TextContent | ImageContent] = [TextContent(type="text", text=json.dumps(data, ensure_ascii=False))]
    if isinstance(result, WithImage) and result.image is not None and result.image_bytes is not None:
        encoded = base64.b64encode(result.image_bytes).decode("ascii")
        content.append(ImageContent(type="image", data=encoded, mime_type=result.image.mime_type))
    return CallToolResult(content=content, structured_content=data, is_error=data.get("status") == "failure")


def _progress(ctx: Context[AppState]) -> ProgressFn:
    """A progress callback for the worker thread that sends MCP progress notifications."""

    def report(done: float, total: float, message: str) -> None:
        anyio.from_thread.run(ctx.report_progress, done, total, message)

    return report


def _model_label(ctx: Context[AppState]) -> str | None:
    meta = ctx.request_context.meta or {}
    label = meta.get(MODEL_META_KEY)
    if isinstance(label, str) and label:
        return label
    params = ctx.request_context.session.client_params
    if params is not None:
        return f"{params.client_info.name}/{params.client_info.version}"
    return None


@dataclass
class Access:
    """Who may act: the consent gate when actions need the user's permission (`--confirm-actions`).
    Whether the caller may act on its robot at all is the robot's lease (one driver at a time)."""

    gate: ConsentGate | None = None

    def asks_consent(self, tool: Tool[Any]) -> bool:
        return self.gate is not None and tool.kind == "robot" and tool.changes_world


def register_tool(mcp: MCPServer[AppState], tool: Tool[Any], access: Access) -> None:
    """Publish `tool`: its arguments become the input schema, its result model the output schema.

    The handler the SDK sees has the tool's own parameters (keyword-only) plus the request context;
    the call runs on the session, serialised, and a result with status "failure" is a tool error.
    A tool that is not read-only needs the robot's lease (see `ownership.py`); with a consent gate,
    an action first asks the user (see `consent.py`).
    """
    exclusive = not tool.annotations.read_only_hint
    gate = access.gate if access.asks_consent(tool) else None

    async def handler(ctx: Context[AppState], **arguments: Any) -> CallToolResult:
        events = ctx.request_context.lifespan_context.events
        if events is None:
            return await act(ctx, arguments)
        shown = {k: v for k, v in arguments.items() if k != "consent"}
        return await events.observe(tool.name, shown, lambda: act(ctx, arguments), client=_model_label(ctx))

    async def act(ctx: Context[AppState], arguments: dict[str, Any]) -> CallToolResult:
        state = ctx.request_context.lifespan_context
        if gate is not None:
            gate.check(ctx, tool, arguments.pop("consent"))
        # A call that needs a robot of its own (one that acts, or any on a fleet) gets a sessionless
        # client a driver id when it sends none; the id goes back in the result's _meta.
        driver = Driver.of(ctx.request_context, state.ids, issue=exclusive or not state.fleet.shared)
        try:
            result = await run(ctx, state, driver, arguments)
        except ToolError as exc:
            if driver is None or not driver.issued_now:
                raise
            failed = CallToolResult(content=[TextContent(type="text", text=str(exc))], is_error=True)
            failed.meta = {DRIVER_META_KEY: driver.driver_id}
            return failed
        if driver is not None and driver.issued_now:
            result.meta = {**(result.meta or {}), DRIVER_META_KEY: driver.driver_id}
        return result

    async def run(
        ctx: Context[AppState], state: AppState, driver: Driver | None, arguments: dict[str, Any]
    ) -> CallToolResult:
        robot = await state.robot(ctx.request_context, driver)
        # A watcher's read-only calls on a shared robot are not the driver's episode's calls.
        counts = not state.fleet.shared or robot.lease.holds(driver)
        if exclusive:
            assert driver is not None
            try:
                robot.lease.claim(driver)
            except RobotBusy as exc:
                raise ToolError(str(exc)) from None
        caller = Caller(progress=_progress(ctx), model=_model_label(ctx), counts=counts)
        records: list[LogEntry] = []
        try:
            with collecting(records.append):
                result = await state.run_on(robot, lambda session: session.invoke(tool, arguments, caller))
        finally:
            await state.clients.send(ctx.request_context, records)
        if tool.changes_world and getattr(result, "status", None) != "failure":
            if state.fleet.shared:
                await state.clients.world_changed()
                for uri in WORLD_RESOURCES:  # clients on 2026-07-28 and later listen on subscriptions/listen
                    await ctx.notify_resource_updated(uri)
            else:  # a fleet's robots are private: only the caller's own subscriptions hear of it
                await state.clients.world_changed(only=connection_of(ctx.request_context))
        return _tool_result(result)

    keyword = inspect.Parameter.KEYWORD_ONLY
    parameters = [p.replace(kind=keyword) for p in tool.parameters]
    context = inspect.Parameter("ctx", keyword, annotation=Context[AppState])
    extra = [gate.parameter(tool)] if gate is not None else []
    returns = Annotated[CallToolResult, tool.result_type]
    handler.__signature__ = inspect.Signature([*parameters, context, *extra], return_annotation=returns)  # type: ignore[attr-defined]
    handler.__annotations__ = {p.name: p.annotation for p in [*parameters, *extra]} | {
        "ctx": Context[AppState],
        "return": returns,
    }
    handler.__name__ = handler.__qualname__ = tool.name
    mcp.add_tool(handler, name=tool.name, title=tool.title, description=tool.description, annotations=tool.annotations)


class RobocogServer(MCPServer[AppState]):
    """MCPServer, with argument errors a model can read: "Invalid arguments for move_to: location:
    Input should be a valid string (got 5)." instead of pydantic's report (its model name, its
    documentation URL, and up to 200 characters of what was sent back again)."""

    async def call_tool(
        self, name: str, arguments: dict[str, Any], context: Context[AppState, Any] | None = None
    ) -> CallToolResult | InputRequiredResult:
        try:
            return await super().call_tool(name, arguments, context)
        except ToolError as exc:
            if not isinstance(exc.__cause__, ValidationError):
                raise
            raise ToolError(invalid_arguments(name, exc.__cause__)) from exc.__cause__

    async def read_resource(
        self, uri: Any, context: Context[AppState, Any] | None = None
    ) -> Iterable[ReadResourceContents] | InputRequiredResult:
        """Resources read the caller's robot: the request is remembered for them (see `_REQUEST`)."""
        token = _REQUEST.set(None if context is None else context.request_context)
        try:
            return await super().read_resource(uri, context)
        except UnexpectedResourceError as exc:
            if isinstance(exc.__cause__, ToolError):  # ours, written for the client (no robot, no id)
                raise ResourceError(str(exc.__cause__)) from exc.__cause__
            raise
        finally:
            _REQUEST.reset(token)


def invalid_arguments(tool: str, error: ValidationError) -> str:
    """One line per problem: the argument, what is wrong, and (for a wrong type) a glimpse of the value."""
    problems = []
    for item in error.errors(include_url=False):
        where = ".".join(str(part) for part in item["loc"]) or "arguments"
        got = "" if item["type"] in ("missing", "text_too_long") else f" (got {_glimpse(item.get('input'))})"
        problems.append(f"{where}: {item['msg']}{got}")
    return f"Invalid arguments for {tool}: {'; '.join(problems)}. Its input schema says what each argument takes."


def _glimpse(value: object) -> str:
    text = json.dumps(value, ensure_ascii=False, default=str)
    return text if len(text) <= 40 else text[:37] + "..."


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

    lowlevel = mcp._lowlevel_server
    lowlevel.add_request_handler("logging/setLevel", SetLevelRequestParams, set_level)
    lowlevel.add_request_handler("resources/subscribe", SubscribeRequestParams, subscribe)
    lowlevel.add_request_handler("resources/unsubscribe", UnsubscribeRequestParams, unsubscribe)


#: The identity rule, published as an experimental capability so that the contract (and `robocog
#: contract check`) sees it: over HTTP without a session, a driver is the id the server issued.
DRIVER_RULE = {"issued": True}


def publish_driver_rule(mcp: MCPServer[AppState]) -> None:
    """Declare `experimental["robocog/driver"]` in the server's capabilities, on every protocol
    generation (the SDK builds them in more than one place, all through `get_capabilities`)."""
    lowlevel = mcp._lowlevel_server
    original = lowlevel.get_capabilities

    def get_capabilities(*args: Any, **kwargs: Any) -> Any:
        capabilities = original(*args, **kwargs)
        experimental = {**(capabilities.experimental or {}), DRIVER_META_KEY: DRIVER_RULE}
        return capabilities.model_copy(update={"experimental": experimental})

    lowlevel.get_capabilities = get_capabilities  # type: ignore[method-assign]


def _auth(access: AccessConfig) -> dict[str, Any]:
    """The SDK's auth arguments for a bearer token (none without one)."""
    if access.auth_token is None:
        return {}
    from robocog.server.http import BearerToken, auth_settings

    return {"auth": auth_settings(access.url), "token_verifier": BearerToken(access.auth_token)}


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
) -> MCPServer[AppState]:
    """The robocog MCP server for `config`; the `eval` profile adds the harness controls; `access`
    sets the bearer token, the consent gate, the published tools and the lease; `view`, a port,
    serves the live viewer there (127.0.0.1; 0 picks a free port) from this process; `robots` > 1
    makes it a fleet: each driver (an HTTP session, a connection) gets a robot of its own (as with
    `per_driver`, for one robot too: a fleet's process behind a router)."""
    config = config or SessionConfig()
    access = access or AccessConfig()
    if robots < 1:
        raise ConfigError(f"--robots: a server has at least one robot, not {robots}")
    if robots > 1 and view is not None:
        raise ConfigError("--view watches one robot: it cannot be combined with a fleet (--robots above 1)")
    if access.allow_tools is not None:
        unknown = access.allow_tools - {t.name for t in ROBOT_TOOLS}
        if unknown:
            known = ", ".join(t.name for t in ROBOT_TOOLS)
            raise ConfigError(f"--allow-tools: no tool called {', '.join(sorted(unknown))}; the tools are {known}")
    current = Current()

    @asynccontextmanager
    async def lifespan(_: MCPServer[AppState]) -> AsyncIterator[AppState]:
        fleet = Fleet(
            config,
            capacity=robots,
            per_driver=per_driver,
            idle_s=access.lease_idle_s,
            open_namespaces=open_namespaces,
        )
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
                tg.start_soon(viewer.run)
            try:
                yield state
            finally:
                if viewer is not None:
                    viewer.stop()
                await state.ready.wait()
                current.state = None
                await anyio.to_thread.run_sync(fleet.close)

    mcp: MCPServer[AppState] = RobocogServer(
        "robocog",
        title="robocog household robot",
        instructions=INSTRUCTIONS,
        version=__version__,
        lifespan=lifespan,
        log_level=log_level,
        **_auth(access),
    )
    install_log_handlers(log_level)
    guard = Access(gate=ConsentGate() if access.confirm_actions else None)
    published = [t for t in ROBOT_TOOLS if access.allow_tools is None or t.name in access.allow_tools]
    for tool in published + list(CONTROL_TOOLS if profile == "eval" else ()):
        register_tool(mcp, tool, guard)
    register_resources(mcp, current)
    register_prompts(mcp)
    register_completions(mcp, current)
    register_logging_and_subscriptions(mcp)
    publish_driver_rule(mcp)
    return mcp
