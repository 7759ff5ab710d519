"""Inspect's entry point (`[project.entry-points.inspect_ai]`): importing the tasks registers them
as `robocog/t1`, `robocog/t2` and `robocog/suite`, and the scripted planner as the model provider
`robocog` (`--model robocog/planner`)."""

from robocog.inspect._planner import robocog_planner
from robocog.inspect._suite import suite
from robocog.inspect._tasks import t1, t2

__all__ = ["robocog_planner", "suite", "t1", "t2"]
