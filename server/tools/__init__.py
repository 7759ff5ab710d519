"""Every tool the server publishes, one module each (or one per small family), in one list.

Adding a tool: write `robocog/server/tools/NAME.py` with its run function and `TOOL = Tool(...)`
(see `base.py`), then add it to `ROBOT_TOOLS` (or `CONTROL_TOOLS`) below. The app registers these
lists generically; the contract snapshot in tests/snapshots shows the change.
"""

from robocog.server.tools import (
    controls,
    end_task,
    furniture,
    grab,
    look,
    look_around,
    move_to,
    place,
    robot_view,
    scratchpad,
    search_memory,
)
from robocog.server.tools.base import Tool

#: Offered to models, in the paper's order, then ours (look: the camera; open and close: furniture).
ROBOT_TOOLS: tuple[Tool, ...] = (
    look_around.TOOL,
    move_to.TOOL,
    grab.TOOL,
    place.TOOL,
    scratchpad.ADD,
    scratchpad.VIEW,
    end_task.TOOL,
    search_memory.TOOL,
    look.TOOL,
    furniture.OPEN,
    furniture.CLOSE,
)

#: The eval profile's harness controls (never offered to a model).
CONTROL_TOOLS: tuple[Tool, ...] = (
    controls.RESET_WORLD,
    controls.BEGIN_TASK,
    controls.CHECK_TASK,
    controls.CLEAR_MEMORY,
)

#: The robot app's own tools (`robocog.server.wiring.ui`): hidden from models, left out with `--no-app`.
APP_TOOLS: tuple[Tool, ...] = (robot_view.TOOL,)

__all__ = ["APP_TOOLS", "CONTROL_TOOLS", "ROBOT_TOOLS", "Tool"]
