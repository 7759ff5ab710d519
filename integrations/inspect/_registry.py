"""Inspect's entry point (`[project.entry-points.inspect_ai]`): importing the tasks registers them
as `robocog/t1` and `robocog/t2`."""

from robocog.inspect._tasks import t1, t2

__all__ = ["t1", "t2"]
