"""robocog as Inspect (`inspect_ai`) tasks: `inspect eval robocog/t1 --model ...`, `robocog/t2`, and
`robocog/suite` (the task suite, one sample per instance) (the `inspect` extra).

Each sample is one episode on its own `robocog-server --profile eval` over stdio; Inspect's `react()`
drives the eight robot tools through `mcp_tools`, and the score is `check_task`'s ground truth beside
the status the model claimed with end_task. See `robocog.inspect._tasks` and `robocog.inspect._suite`.
"""

from robocog.inspect._planner import planner_outputs
from robocog.inspect._suite import suite, suite_agent, suite_instances, suite_verdict
from robocog.inspect._tasks import (
    ROBOT_TOOL_NAMES,
    believed_status,
    robocog_agent,
    robocog_server,
    robocog_task,
    robocog_verdict,
    t1,
    t2,
)

__all__ = [
    "ROBOT_TOOL_NAMES",
    "believed_status",
    "planner_outputs",
    "robocog_agent",
    "robocog_server",
    "robocog_task",
    "robocog_verdict",
    "suite",
    "suite_agent",
    "suite_instances",
    "suite_verdict",
    "t1",
    "t2",
]
