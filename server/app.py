"""The MCP surface: the robot's tools, its resources and prompts, on mcp 2.x's `MCPServer`.

This module only wires: what each tool does lives in its module under `robocog.server.tools`,
and every tool is registered the same way from the lists there. One server is one robot:
calls are serialised (a lock, and the work runs on a worker thread) so the PyBullet client has
one driver at a time, and an action runs to its end even when the call is cancelled, so the world
is always left consistent.
"""

from __future__ import annotations

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
    SetLevelRequestParams,
    SubscribeRequestParams,
    TextContent,
    UnsubscribeRequestParams,
)
from pydantic import BaseModel

from robocog.server.clients import WORLD_RESOURCES, Clients, LogEntry, collecting, install_log_handlers
from robocog.server.config import SessionConfig
from robocog.server.resources import Current, register_completions, register_prompts, register_resources
from robocog.server.tools import CONTROL_TOOLS, ROBOT_TOOLS
from robocog.server.tools.base import Caller, ProgressFn, Tool
from robocog.shared import __version__
from robocog.shared.protocol import CONTRACT_VERSION, MODEL_META_KEY

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
    """Structured content plus the same JSON as text; a failed action is marked as a tool error."""
    data = result.model_dump(mode="json")
    return CallToolResult(
        content=[TextContent(type="text", text=json.dumps(data, ensure_ascii=False))],
        structured_content=data,
        is_error=data.get("status") == "failure",
    )


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


def register_tool(mcp: MCPServer[AppState], tool: Tool[Any]) -> None:
    """Publish `tool`: its arguments become the input schema, its result model the output schema.

    The handler the SDK sees has the tool's own parameters (keyword-only) plus the request context;
    the call runs on the session, serialised, and a result with status "failure" is a tool error.
    """

    async def handler(ctx: Context[AppState], **arguments: Any) -> CallToolResult:
        state = ctx.request_context.lifespan_context
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
    returns = Annotated[CallToolResult, tool.result_type]
    handler.__signature__ = inspect.Signature([*parameters, context], return_annotation=returns)  # type: ignore[attr-defined]
    handler.__annotations__ = {p.name: p.annotation for p in parameters} | {"ctx": Context[AppState], "return": returns}
    handler.__name__ = handler.__qualname__ = tool.name
    mcp.add_tool(handler, name=tool.name, title=tool.title, description=tool.description, annotations=tool.annotations)


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


def build_server(
    config: SessionConfig | None = None,
    *,
    profile: Profile = "default",
    log_level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = "WARNING",
) -> MCPServer[AppState]:
    """The robocog MCP server for `config`; the `eval` profile adds the harness controls."""
    config = config or SessionConfig()
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

        async with anyio.create_task_group() as tg:
            tg.start_soon(build)
            try:
                yield state
            finally:
                await state.ready.wait()
                current.state = None
                if state._session is not None:
                    await anyio.to_thread.run_sync(state._session.close)

    mcp: MCPServer[AppState] = MCPServer(
        "robocog",
        title="robocog household robot",
        instructions=INSTRUCTIONS,
        version=__version__,
        lifespan=lifespan,
        log_level=log_level,
    )
    install_log_handlers(log_level)
    for tool in ROBOT_TOOLS + (CONTROL_TOOLS if profile == "eval" else ()):
        register_tool(mcp, tool)
    register_resources(mcp, current)
    register_prompts(mcp)
    register_completions(mcp, current)
    register_logging_and_subscriptions(mcp)
    return mcp
