"""The MCP surface: the robot's tools, its resources and prompts, on mcp 2.x's `MCPServer`.

This module only wires; what each tool does lives in `RobotSession`. One server is one robot:
calls are serialised (a lock, and the work runs on a worker thread) so the PyBullet client has
one driver at a time, and an action runs to its end even when the call is cancelled, so the world
is always left consistent.
"""

from __future__ import annotations

import functools
import inspect
import json
import logging
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeVar

import anyio
import anyio.from_thread
import anyio.to_thread
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ToolError
from mcp_types import CallToolResult, TextContent, ToolAnnotations
from pydantic import BaseModel, Field

from robocog.assets import ASSETS_DIR
from robocog.server.config import SessionConfig
from robocog.shared import __version__
from robocog.shared.errors import WorldError
from robocog.shared.protocol import MODEL_META_KEY
from robocog.shared.results import (
    EndTaskResult,
    GrabResult,
    LookAroundResult,
    MemorySearchResult,
    MoveResult,
    PlaceResult,
    ScratchpadResult,
    ScratchpadView,
    TaskVerdict,
    WorldState,
)

if TYPE_CHECKING:
    from robocog.server.session import RobotSession

Profile = Literal["default", "eval"]
logger = logging.getLogger("robocog.server")
T = TypeVar("T")

INSTRUCTIONS = (
    "A simulated household robot (PyBullet): a mobile manipulator in a kitchen, hallway and living room. "
    "Drive it with look_around, move_to, grab and place; think on the scratchpad; search episodic memory "
    "for past experiences; finish every task with end_task. The robot_system prompt explains the method."
)


@dataclass
class AppState:
    """What the lifespan owns: the robot session (built in the background) and the lock that
    serialises access to it."""

    lock: anyio.Lock = field(default_factory=anyio.Lock)
    ready: anyio.Event = field(default_factory=anyio.Event)
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

    async def run(self, fn: Callable[..., T], *args: Any) -> T:
        """Run `fn(session, *args)` on a worker thread, one call at a time, to completion.

        A `ValueError` (bad input the caller can fix) becomes a tool error with its message.
        """
        session = await self.wait_ready()
        async with self.lock:
            try:
                # abandon_on_cancel=False: a cancelled call still finishes its action first.
                return await anyio.to_thread.run_sync(functools.partial(fn, session, *args), abandon_on_cancel=False)
            except ValueError as exc:
                raise ToolError(str(exc)) from exc

    async def call(self, method: str, *args: Any) -> Any:
        """Run the session's `method(*args)` (see `run`)."""
        return await self.run(lambda session, *a: getattr(session, method)(*a), *args)


def _state(ctx: Context[AppState]) -> AppState:
    return ctx.request_context.lifespan_context


def _tool_result(result: BaseModel) -> CallToolResult:
    """Structured content plus the same JSON as text; a failed action is marked as a tool error."""
    data = result.model_dump(mode="json")
    return CallToolResult(
        content=[TextContent(type="text", text=json.dumps(data, ensure_ascii=False))],
        structured_content=data,
        is_error=data.get("status") == "failure",
    )


def _progress(ctx: Context[AppState]) -> Callable[[float, float, str], None]:
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


READ_ONLY = ToolAnnotations(read_only_hint=True, open_world_hint=False)
ACTION = ToolAnnotations(read_only_hint=False, destructive_hint=False, idempotent_hint=False, open_world_hint=False)
IDEMPOTENT_ACTION = ToolAnnotations(
    read_only_hint=False, destructive_hint=False, idempotent_hint=True, open_world_hint=False
)

LocationArg = Annotated[
    str,
    Field(
        description="A location on the robot's map, as look_around names it, e.g. 'Kitchen Shelf'",
        min_length=1,
        max_length=200,
    ),
]


def _tool(mcp: MCPServer[AppState], title: str, annotations: ToolAnnotations) -> Callable[[Callable[..., Any]], Any]:
    """Register a tool whose description is its docstring, dedented."""

    def register(fn: Callable[..., Any]) -> Callable[..., Any]:
        mcp.add_tool(fn, title=title, description=inspect.cleandoc(fn.__doc__ or ""), annotations=annotations)
        return fn

    return register


def register_robot_tools(mcp: MCPServer[AppState]) -> None:
    """The paper's eight tools."""

    @_tool(mcp, "Look around", READ_ONLY)
    async def look_around(ctx: Context[AppState]) -> Annotated[CallToolResult, LookAroundResult]:
        """Perceive the world: where the robot is, what it holds, and for every location its objects,
        its place positions (free or occupied) and its neighbouring locations."""
        s = _state(ctx)
        return _tool_result(await s.call("look_around"))

    @_tool(mcp, "Move to a location", IDEMPOTENT_ACTION)
    async def move_to(location: LocationArg, ctx: Context[AppState]) -> Annotated[CallToolResult, MoveResult]:
        """Drive the robot to a location along the shortest path on its map (A*). Fails with the
        closest known names if the location does not exist, or if there is no path."""
        s = _state(ctx)
        return _tool_result(await s.call("move_to", location, _progress(ctx)))

    @_tool(mcp, "Grab an object", ACTION)
    async def grab(
        object: Annotated[
            str,
            Field(
                description="The object to pick up, e.g. 'mug'; it must be at the robot's location",
                min_length=1,
                max_length=200,
            ),
        ],
        ctx: Context[AppState],
    ) -> Annotated[CallToolResult, GrabResult]:
        """Reach for an object at the robot's location and hold it. The robot holds one object at a
        time; fails if the object is unknown, elsewhere, out of reach, too large to grasp, or if the
        hand is already full."""
        s = _state(ctx)
        return _tool_result(await s.call("grab", object))

    @_tool(mcp, "Place the held object", ACTION)
    async def place(
        location: LocationArg,
        position: Annotated[
            str,
            Field(
                description="A place position of that location as look_around lists it, e.g. 'top', "
                "'middle', 'bottom' or 'floor'",
                min_length=1,
                max_length=200,
            ),
        ],
        ctx: Context[AppState],
    ) -> Annotated[CallToolResult, PlaceResult]:
        """Put the held object down on a free place position of the location where the robot is.
        Fails if nothing is held, the robot is elsewhere, the position is unknown or occupied
        (the message lists the free positions)."""
        s = _state(ctx)
        return _tool_result(await s.call("place", location, position))

    @_tool(mcp, "Write to the scratchpad", ACTION)
    async def add_to_scratchpad(
        text: Annotated[str, Field(description="A thought, plan or observation to keep for this task", min_length=1)],
        ctx: Context[AppState],
    ) -> Annotated[CallToolResult, ScratchpadResult]:
        """Write down thoughts and plans on the scratchpad, the working memory of the current task.
        It is bounded: the oldest entries are dropped when it is full."""
        s = _state(ctx)
        return _tool_result(await s.call("add_to_scratchpad", text))

    @_tool(mcp, "Read the scratchpad", READ_ONLY)
    async def view_scratchpad(ctx: Context[AppState]) -> Annotated[CallToolResult, ScratchpadView]:
        """Read everything written on the scratchpad during the current task, oldest first."""
        s = _state(ctx)
        return _tool_result(await s.call("view_scratchpad"))

    @_tool(mcp, "End the task", ACTION)
    async def end_task(
        status: Annotated[
            Literal["success", "failure"],
            Field(description="'success' only if the task is really done, else 'failure'"),
        ],
        description: Annotated[str, Field(description="The task as you were given it", min_length=1)],
        summary: Annotated[
            str, Field(description="What you did, what went wrong, and what to do differently next time")
        ],
        ctx: Context[AppState],
    ) -> Annotated[CallToolResult, EndTaskResult]:
        """End the current task with a report. The report is stored in episodic memory, searchable
        by the task description, so later tasks can learn from it."""
        s = _state(ctx)
        result = await s.call("end_task", status, description, summary, _model_label(ctx))
        return _tool_result(result)

    @_tool(mcp, "Search episodic memory", READ_ONLY)
    async def search_memory(
        query: Annotated[str, Field(description="A description of the current task, e.g. its instruction")],
        ctx: Context[AppState],
        k: Annotated[int, Field(description="How many experiences to return", ge=1, le=20)] = 3,
    ) -> Annotated[CallToolResult, MemorySearchResult]:
        """Search past experiences (task reports written by end_task) by semantic similarity to the
        query. Each result gives the task, how it ended and the summary of what was done."""
        s = _state(ctx)
        return _tool_result(await s.call("search_memory", query, k))


class ClearMemoryResult(BaseModel):
    """The outcome of clear_memory."""

    removed: int = Field(description="records removed from this memory namespace")


def register_eval_tools(mcp: MCPServer[AppState]) -> None:
    """Controls for evaluation harnesses (the `eval` profile only)."""

    @_tool(mcp, "Reset the world", ToolAnnotations(read_only_hint=False, destructive_hint=True, open_world_hint=False))
    async def reset_world(
        ctx: Context[AppState],
        seed: Annotated[int | None, Field(description="Seed of the world's random generator")] = None,
        randomize: Annotated[bool, Field(description="Start objects on seeded random free positions")] = False,
        memory_labels: Annotated[
            Literal["believed", "verified"] | None,
            Field(description="What search_memory reports as an episode's status from now on"),
        ] = None,
    ) -> WorldState:
        """Put the world back to its start state and begin a new episode. Episodic memory is kept."""
        s = _state(ctx)
        return await s.call("reset_world", seed, randomize, memory_labels)

    @_tool(mcp, "Check a task", ToolAnnotations(read_only_hint=False, open_world_hint=False))
    async def check_task(
        task_id: Annotated[str, Field(description="A task id from robocog://tasks, e.g. 'T1'")],
        ctx: Context[AppState],
    ) -> TaskVerdict:
        """The ground-truth verdict of a task for the world as it is now, with a reason per object.
        If the episode ended with a report, the verdict is written into that memory record."""
        s = _state(ctx)
        return await s.call("check_task", task_id)

    @_tool(
        mcp,
        "Clear episodic memory",
        ToolAnnotations(read_only_hint=False, destructive_hint=True, open_world_hint=False),
    )
    async def clear_memory(ctx: Context[AppState]) -> ClearMemoryResult:
        """Forget every stored episode in this server's memory namespace."""
        s = _state(ctx)
        return ClearMemoryResult(removed=await s.call("clear_memory"))


class _Current:
    """The running server's state, for static resources (the SDK gives those no Context)."""

    state: AppState | None = None

    def get(self) -> AppState:
        if self.state is None:
            raise WorldError("the robot session is not running")
        return self.state


def register_resources(mcp: MCPServer[AppState], current: _Current) -> None:
    @mcp.resource(
        "robocog://world/state", name="world_state", title="World state (ground truth)", mime_type="application/json"
    )
    async def world_state() -> str:
        """Ground truth: the robot's location, pose and hand, each object's place, each position's occupant."""
        s = current.get()
        return (await s.call("state")).model_dump_json(indent=2)

    @mcp.resource("robocog://world/map", name="world_map", title="Semantic map", mime_type="application/json")
    async def world_map() -> str:
        """The semantic map: locations with coordinates and neighbours, edges, place positions."""
        s = current.get()
        return json.dumps(await s.call("semantic_map"), indent=2)

    @mcp.resource("robocog://world/image", name="world_image", title="Top-down view", mime_type="image/png")
    async def world_image() -> bytes:
        """A top-down picture of the world with locations, objects and the robot labelled (PNG)."""
        from robocog.server.render import render_top_down

        s = current.get()
        return await s.run(lambda session: render_top_down(session.world))

    @mcp.resource("robocog://tasks", name="tasks", title="Task catalogue", mime_type="application/json")
    async def tasks() -> str:
        """The tasks the server can check, with their prompts and success conditions."""
        from robocog.server.world.tasks import task_catalogue

        return json.dumps([t.model_dump(mode="json") for t in task_catalogue().values()], indent=2)


def robot_system_prompt() -> str:
    """The system prompt for an agent driving the robot."""
    return (ASSETS_DIR / "prompts" / "robot_system.md").read_text(encoding="utf-8").strip()


def register_prompts(mcp: MCPServer[AppState]) -> None:
    @mcp.prompt(name="robot_system", title="Robot system prompt")
    def robot_system() -> str:
        """The system prompt for an agent that drives the robot with these tools."""
        return robot_system_prompt()

    from robocog.server.world.tasks import task_catalogue

    for task in task_catalogue().values():

        def make(prompt: str) -> Callable[[], str]:
            def task_prompt() -> str:
                return prompt

            return task_prompt

        mcp.prompt(name=task.id, title=f"{task.id}: {task.title}", description=task.prompt)(make(task.prompt))


def build_server(
    config: SessionConfig | None = None,
    *,
    profile: Profile = "default",
    session_factory: Callable[[SessionConfig], RobotSession] | None = None,
    log_level: Literal["DEBUG", "INFO", "WARNING", "ERROR"] = "WARNING",
) -> MCPServer[AppState]:
    """The robocog MCP server for `config`; the `eval` profile adds the harness controls."""
    config = config or SessionConfig()
    current = _Current()

    @asynccontextmanager
    async def lifespan(_: MCPServer[AppState]) -> AsyncIterator[AppState]:
        state = current.state = AppState()

        async def build() -> None:
            # In the background: the server answers initialize and tools/list meanwhile.
            try:
                factory = session_factory
                if factory is None:
                    from robocog.server.session import RobotSession

                    factory = RobotSession
                state._session = await anyio.to_thread.run_sync(factory, config)
            except Exception as exc:  # reported to every caller, the server keeps running
                logger.exception("the robot session could not be built")
                state.failure = f"{type(exc).__name__}: {exc}"
            finally:
                state.ready.set()

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
    register_robot_tools(mcp)
    if profile == "eval":
        register_eval_tools(mcp)
    register_resources(mcp, current)
    register_prompts(mcp)
    return mcp
