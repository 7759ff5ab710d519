"""The MCP surface: the robot's tools, its resources and prompts, on mcp 2.x's `MCPServer`.

This module only wires: what each tool does lives in its module under `robocog.server.tools`,
and every tool is registered the same way from the lists there. One server is one robot:
calls are serialised (a lock, and the work runs on a worker thread) so the PyBullet client has
one driver at a time, and an action runs to its end even when the call is cancelled, so the world
is always left consistent. One client at a time may change anything (the lease, `ownership.py`);
with `--confirm-actions` the user allows each action first (`consent.py`). HTTP's own limits (the
bearer token, Host/Origin, sessions) are in `http.py`.
"""

from __future__ import annotations

import base64
import inspect
import json
import logging
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeVar

import anyio
import anyio.from_thread
import anyio.to_thread
from mcp.server.context import ServerRequestContext
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ToolError
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

from robocog.server.clients import WORLD_RESOURCES, Clients, LogEntry, collecting, install_log_handlers
from robocog.server.config import AccessConfig, SessionConfig
from robocog.server.consent import ConsentGate
from robocog.server.events import EventBus
from robocog.server.ownership import Driver, RobotBusy, RobotLease
from robocog.server.resources import Current, register_completions, register_prompts, register_resources
from robocog.server.tools import CONTROL_TOOLS, ROBOT_TOOLS
from robocog.server.tools.base import Caller, ProgressFn, Tool
from robocog.shared import __version__
from robocog.shared.errors import ConfigError
from robocog.shared.protocol import CONTRACT_VERSION, MODEL_META_KEY
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


@dataclass
class AppState:
    """What the lifespan owns: the robot session (built in the background) and the lock that
    serialises access to it."""

    lock: anyio.Lock = field(default_factory=anyio.Lock)
    ready: anyio.Event = field(default_factory=anyio.Event)
    clients: Clients = field(default_factory=Clients)
    _session: RobotSession | None = None
    failure: str | None = None
    #: The live viewer's events (`robocog-server --view`); None without a viewer.
    events: EventBus | None = None

    @property
    def session(self) -> RobotSession:
        if self._session is None:
            raise ToolError(f"the robot is not available: {self.failure or 'still starting'}")
        return self._session

    async def wait_ready(self) -> RobotSession:
        await self.ready.wait()
        return self.session

    async def run(self, fn: Callable[[RobotSession], T]) -> T:
        """Run `fn(session)` on a worker thread, one call at a time, to completion.

        A `ValueError` (bad input the caller can fix) becomes a tool error with its message.
        """
        session = await self.wait_ready()
        async with self.lock:
            try:
                # abandon_on_cancel=False: a cancelled call still finishes its action first.
                return await anyio.to_thread.run_sync(fn, session, abandon_on_cancel=False)
            except ValueError as exc:
                raise ToolError(str(exc)) from exc


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
    """Who may act: the lease (one driver at a time), and the consent gate when actions need the
    user's permission (`--confirm-actions`)."""

    lease: RobotLease = field(default_factory=RobotLease)
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
        if exclusive:
            try:
                access.lease.claim(Driver.of(ctx.request_context))
            except RobotBusy as exc:
                raise ToolError(str(exc)) from None
        caller = Caller(progress=_progress(ctx), model=_model_label(ctx))
        records: list[LogEntry] = []
        try:
            with collecting(records.append):
                result = await state.run(lambda session: session.invoke(tool, arguments, caller))
        finally:
            await state.clients.send(ctx.request_context, records)
        if tool.changes_world and getattr(result, "status", None) != "failure":
            await state.clients.world_changed()
            for uri in WORLD_RESOURCES:  # clients on 2026-07-28 and later listen on subscriptions/listen
                await ctx.notify_resource_updated(uri)
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
) -> MCPServer[AppState]:
    """The robocog MCP server for `config`; the `eval` profile adds the harness controls; `access`
    sets the bearer token, the consent gate, the published tools and the lease; `view`, a port,
    serves the live viewer there (127.0.0.1; 0 picks a free port) from this process."""
    config = config or SessionConfig()
    access = access or AccessConfig()
    if access.allow_tools is not None:
        unknown = access.allow_tools - {t.name for t in ROBOT_TOOLS}
        if unknown:
            known = ", ".join(t.name for t in ROBOT_TOOLS)
            raise ConfigError(f"--allow-tools: no tool called {', '.join(sorted(unknown))}; the tools are {known}")
    current = Current()

    @asynccontextmanager
    async def lifespan(_: MCPServer[AppState]) -> AsyncIterator[AppState]:
        state = current.state = AppState()

        async def build() -> None:
            # In the background: the server answers initialize and tools/list meanwhile. Its log
            # records are kept for the clients that set a log level, now or later.
            with collecting(state.clients.keep):
                try:
                    from robocog.server.session import RobotSession

                    started = time.monotonic()
                    session = await anyio.to_thread.run_sync(RobotSession, config)
                    await anyio.to_thread.run_sync(session.warm_up)
                    state._session = session
                    logger.info(
                        "robot ready in %.1f s: scene %r, %d objects, %d locations, profile %s",
                        time.monotonic() - started,
                        session.world.scene.name,
                        len(session.world.object_names),
                        len(session.world.map.points),
                        profile,
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
                if state._session is not None:
                    await anyio.to_thread.run_sync(state._session.close)

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
    guard = Access(
        lease=RobotLease(idle_s=access.lease_idle_s),
        gate=ConsentGate() if access.confirm_actions else None,
    )
    published = [t for t in ROBOT_TOOLS if access.allow_tools is None or t.name in access.allow_tools]
    for tool in published + list(CONTROL_TOOLS if profile == "eval" else ()):
        register_tool(mcp, tool, guard)
    register_resources(mcp, current)
    register_prompts(mcp)
    register_completions(mcp, current)
    register_logging_and_subscriptions(mcp)
    return mcp
