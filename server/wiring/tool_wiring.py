"""A robot tool registered with the MCP server: its handler (the caller's robot, consent, progress,
the structured result and the picture), and the one-line message for invalid arguments."""

from __future__ import annotations

import base64
import inspect
import json
from dataclasses import dataclass
from typing import Annotated, Any

import anyio
import anyio.from_thread
import anyio.to_thread
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ToolError
from mcp_types import (
    CallToolResult,
    ImageContent,
    TextContent,
)
from pydantic import BaseModel, Field, ValidationError, create_model

from robocog.server import compat
from robocog.server.clients import (
    WORLD_RESOURCES,
    LogEntry,
    collecting,
    connection_of,
)
from robocog.server.robots.consent import ConsentGate
from robocog.server.robots.fleet import FleetFull
from robocog.server.robots.ownership import Driver, RobotBusy
from robocog.server.state import AppState
from robocog.server.tools.base import Caller, ProgressFn, Tool
from robocog.shared.perturbations import PERTURBATION_META_KEY
from robocog.shared.protocol import DRIVER_META_KEY, MODEL_META_KEY, ROBOT_ID_ARG
from robocog.shared.results import WithImage


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


def hand_over(answer: CallToolResult, handle: str) -> CallToolResult:
    """`answer` with the robot handle its call minted: `robot_id` in the structured content (and its JSON
    text), a sentence in the message, and `_meta["robocog/driver"]`, the alias robocog's own client
    reads. Added after the live viewer has seen the answer: a handle is only ever its caller's."""
    data = answer.structured_content
    first = answer.content[0] if answer.content else None
    if isinstance(data, dict):
        data = {**data, ROBOT_ID: handle, "message": f"{data.get('message') or ''} {handed(handle)}".strip()}
        answer.structured_content = data
        text = TextContent(type="text", text=json.dumps(data, ensure_ascii=False))
        answer.content = [text, *answer.content[1:]]
    elif isinstance(first, TextContent):
        answer.content = [TextContent(type="text", text=f"{first.text} {handed(handle)}"), *answer.content[1:]]
    answer.meta = {**(answer.meta or {}), DRIVER_META_KEY: handle}
    return answer


def handed(handle: str) -> str:
    """The sentence that hands a minted robot handle to its caller."""
    return f"Your robot's handle: pass robot_id='{handle}' on later calls to keep driving this robot."


#: The argument every robot tool and control takes (described once, here).
ROBOT_ID = ROBOT_ID_ARG
RobotIdArg = Annotated[
    str | None,
    Field(
        description="Your robot's handle, only for clients without an MCP session (protocol 2026-07-28 over "
        "HTTP): the robot_id a call without one returned. Leave it out over stdio or with a session, or on a "
        "one-robot server where you are the only client.",
        max_length=200,
    ),
]


def with_handle(result_type: type[BaseModel]) -> type[BaseModel]:
    """`result_type` with the optional `robot_id` a result carries when its call minted a handle (the
    output schema declares it; the name and description stay the result's own)."""
    return create_model(
        result_type.__name__,
        __base__=result_type,
        __doc__=result_type.__doc__,
        robot_id=(
            str | None,
            Field(default=None, description="a robot handle minted by this call: pass it as robot_id on later calls"),
        ),
    )


def _progress(ctx: Context[AppState]) -> ProgressFn | None:
    """A progress callback for the worker thread that sends MCP progress notifications, or None when
    the caller sent no progress token (each report is a hop from the worker thread to the loop)."""
    if not _wants_progress(ctx):
        return None

    def report(done: float, total: float, message: str) -> None:
        anyio.from_thread.run(ctx.report_progress, done, total, message)

    return report


def _wants_progress(ctx: Context[AppState]) -> bool:
    """Whether the caller asked for progress: a token in the request's _meta over JSON-RPC; always on
    the SDK's in-process dispatcher, which carries a caller's progress callback without a token (mcp
    2.3 gives a handler no public way to its dispatch context: `_request_outbound` is read here)."""
    request = ctx.request_context
    meta = request.meta or {}
    if meta.get("progress_token") is not None or meta.get("progressToken") is not None:
        return True
    return compat.transport_kind(request.session) == "direct"


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


def register_tool(
    mcp: MCPServer[AppState], tool: Tool[Any], access: Access, meta: dict[str, Any] | None = None
) -> None:
    """Publish `tool`: its arguments become the input schema, its result model the output schema;
    `meta` is its `_meta` (the robot app's page, `ui.py`).

    The handler the SDK sees has the tool's own parameters (keyword-only) plus the request context;
    the call runs on the session, serialised, and a result with status "failure" is a tool error.
    A tool that is not read-only needs the robot's lease (see `ownership.py`); with a consent gate,
    an action first asks the user (see `consent.py`).
    """
    exclusive = not tool.annotations.read_only_hint
    gate = access.gate if access.asks_consent(tool) else None

    async def handler(ctx: Context[AppState], **arguments: Any) -> CallToolResult:
        events = ctx.request_context.lifespan_context.events
        minted: list[str] = []  # a handle this call mints for its caller (act says), handed over last
        if events is None or tool.kind == "app":  # the live viewer shows the robot's calls, not the app's
            answer = await act(ctx, arguments, minted)
        else:
            shown = {k: v for k, v in arguments.items() if k not in ("consent", ROBOT_ID)}
            call = lambda: act(ctx, arguments, minted)  # noqa: E731
            answer = await events.observe(tool.name, shown, call, client=_model_label(ctx))
        return hand_over(answer, minted[0]) if minted else answer

    async def act(ctx: Context[AppState], arguments: dict[str, Any], minted: list[str]) -> CallToolResult:
        state = ctx.request_context.lifespan_context
        handle = arguments.pop(ROBOT_ID, None)
        if gate is not None:
            gate.check(ctx, tool, arguments.pop("consent"), handle)
        driver = Driver.of(ctx.request_context, state.ids, handle=handle)
        refusal = state.refusal(driver, tool.name, exclusive=exclusive)
        if refusal is not None:
            raise ToolError(refusal)
        if driver.anonymous and not state.fleet.shared:  # a fleet: a read-only call or reset_world mints a handle
            driver = driver.with_new_handle(state.ids)
        try:
            answer, driver = await run(ctx, state, driver, arguments)
        except ToolError as exc:
            if driver.minted is None or isinstance(exc, FleetFull):  # a handle without a robot is no use
                raise
            minted.append(driver.minted)
            return CallToolResult(content=[TextContent(type="text", text=str(exc))], is_error=True)
        if driver.minted is not None:
            minted.append(driver.minted)
        return answer

    async def run(
        ctx: Context[AppState], state: AppState, driver: Driver, arguments: dict[str, Any]
    ) -> tuple[CallToolResult, Driver]:
        robot = await state.robot(ctx.request_context, driver)
        if exclusive:
            holder = robot.lease.holder
            if holder is not None and holder.key != driver.key and state.fleet.presence.absent(holder):
                robot.lease.release(holder.key)  # its client has gone (the MCP Inspector's CLI exits so)
                await state.fleet.presence.let_go(holder)
            try:
                took = robot.lease.claim(driver)
            except RobotBusy as exc:
                raise ToolError(str(exc)) from None
            if driver.anonymous and (took or tool.name == "reset_world"):
                driver = driver.minting(state.ids)  # the anonymous driver took the robot: a handle, if wanted
        # A watcher's read-only calls on a shared robot are not the driver's episode's calls.
        counts = not state.fleet.shared or robot.lease.holds(driver)
        caller = Caller(progress=_progress(ctx), model=_model_label(ctx), counts=counts)
        records: list[LogEntry] = []
        # The call's log records are collected only for a client that asked for them.
        listening = state.clients.listening(ctx.request_context)
        try:
            with collecting(records.append if listening else None):
                result, happened = await state.run_on(
                    robot,
                    lambda session: (session.invoke(tool, arguments, caller), session.perturbations),
                    tool=tool.name,
                )
        finally:
            if records:
                await state.clients.send(ctx.request_context, records)
        # A blocked open or close failed, but the drawer or door moved as far as it could.
        moved = getattr(result, "status", None) != "failure" or getattr(result, "error", None) == "blocked"
        if tool.changes_world and moved:
            if state.fleet.shared:
                await state.clients.world_changed()
                if compat.anyone_listens(ctx):  # clients on 2026-07-28 and later listen on subscriptions/listen
                    for uri in WORLD_RESOURCES:
                        await ctx.notify_resource_updated(uri)
            else:  # a fleet's robots are private: only the caller's own subscriptions hear of it
                await state.clients.world_changed(only=connection_of(ctx.request_context))
        answer = _tool_result(result)
        if happened:  # what went wrong during the call, for the client's trace (announced or not)
            events = [e.model_dump(mode="json") for e in happened]
            answer.meta = {**(answer.meta or {}), PERTURBATION_META_KEY: events}
        return answer, driver

    keyword = inspect.Parameter.KEYWORD_ONLY
    parameters = [p.replace(kind=keyword) for p in tool.parameters]
    context = inspect.Parameter("ctx", keyword, annotation=Context[AppState])
    handle = inspect.Parameter(ROBOT_ID, keyword, default=None, annotation=RobotIdArg)
    extra = [handle, *([gate.parameter(tool)] if gate is not None else [])]
    returns = Annotated[CallToolResult, with_handle(tool.result_type)]
    handler.__signature__ = inspect.Signature([*parameters, context, *extra], return_annotation=returns)  # type: ignore[attr-defined]
    handler.__annotations__ = {p.name: p.annotation for p in [*parameters, *extra]} | {
        "ctx": Context[AppState],
        "return": returns,
    }
    handler.__name__ = handler.__qualname__ = tool.name
    mcp.add_tool(
        handler,
        name=tool.name,
        title=tool.title,
        description=tool.description,
        annotations=tool.annotations,
        meta=meta,
    )


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
