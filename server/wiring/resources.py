"""The robot's resources, prompts and completions, registered on the MCP server (`app.py` wires them)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Annotated, Any

from mcp.server.mcpserver import MCPServer
from mcp.server.mcpserver.exceptions import ResourceNotFoundError
from mcp_types import Completion, CompletionArgument, CompletionContext, PromptReference, ResourceTemplateReference
from pydantic import Field

from robocog.assets import ASSETS_DIR
from robocog.shared.errors import WorldError

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession
    from robocog.server.state import AppState


class Current:
    """The running server's state, for static resources (the SDK gives those no Context)."""

    state: AppState | None = None

    def get(self) -> AppState:
        if self.state is None:
            raise WorldError("the robot session is not running")
        return self.state


def register_resources(mcp: MCPServer[AppState], current: Current) -> None:
    @mcp.resource(
        "robocog://world/state", name="world_state", title="World state (ground truth)", mime_type="application/json"
    )
    async def world_state() -> str:
        """Ground truth: the robot's location, pose and hand, each object's place, each position's occupant."""
        s = current.get()
        return (await s.run(lambda session: session.state())).model_dump_json(indent=2)

    @mcp.resource("robocog://world/map", name="world_map", title="Semantic map", mime_type="application/json")
    async def world_map() -> str:
        """The semantic map: locations with coordinates and neighbours, edges, place positions."""
        s = current.get()
        return json.dumps(await s.run(lambda session: session.semantic_map()), indent=2)

    @mcp.resource("robocog://world/image", name="world_image", title="Top-down view", mime_type="image/png")
    async def world_image() -> bytes:
        """A top-down picture of the world with locations, objects and the robot labelled (PNG)."""
        from robocog.server.render import render_top_down

        s = current.get()
        return await s.run(lambda session: render_top_down(session.world))

    @mcp.resource(
        "robocog://world/description",
        name="world_description",
        title="Environment description",
        description="The world in words, as the paper's task message gives it: every location with its objects, "
        "its place positions (empty or occupied by what) and its neighbours, then where the robot is.",
        mime_type="text/plain",
    )
    async def world_description() -> str:
        from robocog.server.world.describe import describe

        s = current.get()
        return await s.run(lambda session: describe(session.world))

    @mcp.resource(
        "robocog://objects/{name}",
        name="object",
        title="One object (ground truth)",
        description="Ground truth of one object: where it is (on a place position, held or loose), its pose, "
        "whether it rests, and whether the robot can grasp it. Completions offer the scene's objects.",
        mime_type="application/json",
    )
    async def object_truth(name: str) -> str:
        return json.dumps(await current.get().run(lambda session: object_json(session, name)), indent=2)

    @mcp.resource(
        "robocog://locations/{name}",
        name="location",
        title="One location (ground truth)",
        description="Ground truth of one location: its coordinates and neighbours, its place positions and what "
        "rests on each, the objects there, and whether the robot is there. Completions offer the scene's locations.",
        mime_type="application/json",
    )
    async def location_truth(name: str) -> str:
        return json.dumps(await current.get().run(lambda session: location_json(session, name)), indent=2)

    @mcp.resource("robocog://tasks", name="tasks", title="Task catalogue", mime_type="application/json")
    async def tasks() -> str:
        """The tasks the server can check, with their prompts and success conditions."""
        from robocog.server.world.tasks import task_catalogue

        return json.dumps([t.model_dump(mode="json") for t in task_catalogue().values()], indent=2)


def object_json(session: RobotSession, name: str) -> dict[str, Any]:
    world = session.world
    if name not in world.object_names:
        raise ResourceNotFoundError(f"there is no object called {name!r}; objects: {', '.join(world.object_names)}")
    return world.placement(name).model_dump(mode="json") | {"graspable": world.object_spec(name).graspable}


def location_json(session: RobotSession, name: str) -> dict[str, Any]:
    world = session.world
    points = world.map.points
    if name not in points:
        raise ResourceNotFoundError(f"there is no location called {name!r}; locations: {', '.join(points)}")
    state = world.state()
    x, y = points[name]
    return {
        "name": name,
        "x": x,
        "y": y,
        "neighbours": world.map.neighbours[name],
        "robot_here": state.robot.location == name,
        "place_positions": [
            {"position": p.position, "occupied_by": p.occupied_by} for p in state.positions if p.location == name
        ],
        "objects": [o.object for o in state.objects if o.location == name and o.state != "held"],
    }


def robot_system_prompt(name: str = "robot_system") -> str:
    """A system prompt for an agent driving the robot: `robot_system` (ours) or `robot_system_paper`."""
    return (ASSETS_DIR / "prompts" / f"{name}.md").read_text(encoding="utf-8").strip()


#: The `bring` prompt's text.
BRING = "Bring the {object} to {location}."


def register_prompts(mcp: MCPServer[AppState]) -> None:
    @mcp.prompt(name="robot_system", title="Robot system prompt")
    def robot_system() -> str:
        """The system prompt for an agent that drives the robot with these tools."""
        return robot_system_prompt()

    @mcp.prompt(
        name="robot_system_paper",
        title="Robot system prompt (the paper's protocol)",
        description="The system prompt of the paper's protocol, in our words: the tools and a way of working, "
        "without robocog's additions (no layout, no hints on graspability or on checking success).",
    )
    def robot_system_paper() -> str:
        return robot_system_prompt("robot_system_paper")

    @mcp.prompt(name="bring", title="Bring an object to a location")
    def bring(
        object: Annotated[str, Field(description="An object the robot can carry, e.g. 'mug'")],
        location: Annotated[str, Field(description="A location, e.g. 'Kitchen Table'")],
    ) -> str:
        """Ask the robot to bring one object to one location."""
        return BRING.format(object=object, location=location)

    from robocog.server.world.tasks import task_catalogue

    for task in task_catalogue().values():

        def make(prompt: str) -> Callable[[], str]:
            def task_prompt() -> str:
                return prompt

            return task_prompt

        mcp.prompt(name=task.id, title=f"{task.id}: {task.title}", description=task.prompt)(make(task.prompt))


def complete_names(names: list[str], typed: str) -> Completion:
    """`names` that begin with `typed` (case-insensitive), then those with a later word that does."""
    prefix = typed.casefold()
    first = [n for n in names if n.casefold().startswith(prefix)]
    later = [n for n in names if n not in first and any(w.startswith(prefix) for w in n.casefold().split()[1:])]
    values = first + later
    return Completion(values=values[:100], total=len(values), has_more=len(values) > 100)


def register_completions(mcp: MCPServer[AppState], current: Current) -> None:
    """Argument values for the resource templates and the prompts, from the scene."""

    @mcp.completion()
    async def complete(
        ref: PromptReference | ResourceTemplateReference, argument: CompletionArgument, _: CompletionContext | None
    ) -> Completion | None:
        world = (await current.get().robot()).session.world
        objects, locations = world.object_names, list(world.map.points)
        graspable = [n for n in objects if world.object_spec(n).graspable]
        choices: dict[tuple[str, str], list[str]] = {
            ("robocog://objects/{name}", "name"): objects,
            ("robocog://locations/{name}", "name"): locations,
            ("bring", "object"): graspable,
            ("bring", "location"): locations,
        }
        key = ref.uri if isinstance(ref, ResourceTemplateReference) else ref.name
        names = choices.get((key, argument.name))
        return None if names is None else complete_names(names, argument.value)
