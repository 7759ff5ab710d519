"""look(direction, caption): a picture from the robot's camera, for models that take images.

The picture is a PNG (`camera.WIDTH` x `camera.HEIGHT`) rendered headless from the robot's own
camera (see `robocog.server.world.camera`); the app sends it as an MCP image content block beside the
JSON result, which says where the camera looked. A short caption of what is visible, from ground
truth, comes only when asked for: without it, the picture is all a model learns.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import READ_ONLY, Tool, at_most
from robocog.server.world import camera
from robocog.shared.limits import NAME_CHARS
from robocog.shared.results import LookResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

DirectionArg = Annotated[
    str,
    Field(
        description=(
            "Where to look: 'ahead' (the robot's heading), 'left', 'right' or 'behind', "
            "or toward a location or an object by name, e.g. 'Kitchen Table' or 'mug'"
        ),
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give 'ahead', 'left', 'right', 'behind', or a location or object name"),
]
CaptionArg = Annotated[
    bool, Field(description="Also return a short caption of what is visible (from ground truth); default false")
]


def look(robot: RobotSession, direction: DirectionArg = "ahead", caption: CaptionArg = False) -> LookResult:
    world = robot.world
    view = camera.capture(world, direction)  # a ValueError names the directions and names it takes
    aim = view.aim
    result = LookResult(
        status="success",
        message=(
            f"Looking {aim.direction} from {world.robot_location()} (heading {aim.heading_deg:g} deg, "
            f"tilt {aim.tilt_deg:g} deg): a {view.width}x{view.height} PNG picture follows."
            + (f" {aim.note}" if aim.note else "")
        ),
        location=world.robot_location(),
        direction=aim.direction,
        heading_deg=aim.heading_deg,
        tilt_deg=aim.tilt_deg,
        caption=camera.caption(world, view) if caption else None,
    )
    result.attach_image(camera.encode_png(view.rgb), width=view.width, height=view.height)
    return result


DOC = f"""Take a picture with the robot's camera and return it as an image ({camera.WIDTH}x{camera.HEIGHT} PNG):
the view from a camera {camera.MOUNT_HEIGHT_M:g} m up on the robot, {camera.FOV_ACROSS_DEG:.0f} degrees
wide, looking ahead, left, right or behind the robot, or turned toward a location or an object. With
caption=true the result also says which objects, furniture and locations are visible (from ground
truth). Changes nothing."""

TOOL = Tool("look", "Look through the camera", READ_ONLY, look, doc=DOC)
