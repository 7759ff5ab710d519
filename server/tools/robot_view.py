"""robot_view: what the robot app (`ui://robocog/robot`, an MCP App) draws, for the app alone.

Hosts that render MCP Apps hide it from the model (`_meta.ui.visibility: ["app"]`), and robocog's own
client never offers it (`robocog.shared.protocol.APP_TOOLS`). It only reads: the map's geometry, the
ground truth, the verdict of the episode's task where the server knows the task (a harness began it,
or the episode's end_task named a task of the catalogue by its prompt), and on request a picture from
the robot's camera. It is not one of the episode's calls, and steps no physics.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import READ_ONLY, Tool
from robocog.server.world import camera
from robocog.server.world.geometry import map_geometry
from robocog.server.world.tasks import evaluate
from robocog.shared.results import RobotView

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

SceneArg = Annotated[bool, Field(description="Include the map's geometry (the app asks once)")]
CameraArg = Annotated[bool, Field(description="Attach a picture from the robot's camera, looking ahead")]


def known_task(robot: RobotSession) -> str | None:
    """The episode's task where the server knows it: the one a harness began, else the task of the
    catalogue whose prompt the episode's end_task gave as its description."""
    episode = robot.episode
    if episode.task_id is not None:
        return episode.task_id
    said = " ".join(str((episode.report or {}).get("description", "")).split()).casefold()
    if not said:
        return None
    return next((t.id for t in robot.tasks.values() if " ".join(t.prompt.split()).casefold() == said), None)


def robot_view(robot: RobotSession, scene: SceneArg = True, camera_frame: CameraArg = False) -> RobotView:
    """What the robot app draws: the map, the ground truth, the task's verdict where known. For the
    app (`ui://robocog/robot`) only: a model learns the world from look_around."""
    world = robot.world
    task_id = known_task(robot)
    verdict = None
    if task_id is not None:
        closed = {name: world.furniture(name).state == "closed" for name in world.container_names}
        episode = robot.episode
        verdict = evaluate(robot.task(task_id), world.placements(), episode.baseline, episode.report, closed)
    view = RobotView(
        scene=map_geometry(world) if scene else None,
        world=world.state(),
        task_id=task_id,
        verdict=verdict,
        episode=robot.episode.number,
        tool_calls=robot.episode.tool_calls,
    )
    if camera_frame:
        frame = camera.capture(world, "ahead")
        view.attach_image(camera.encode_png(frame.rgb), width=frame.width, height=frame.height)
    return view


TOOL = Tool("robot_view", "The robot app's view", READ_ONLY, robot_view, kind="app")
