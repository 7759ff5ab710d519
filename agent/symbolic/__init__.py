"""Planning over symbols, pure logic (no MCP, no physics): the one optimal search (`search`), the
names-only world (`world`) with the suite generator's planning problem over it (`plans`), and the
scripted planner's planning problem over what it believes (`rearrangement`). Both problems are
solved by the same search, so "optimal" means one thing (see `search`)."""

from __future__ import annotations

from robocog.agent.symbolic.plans import allowed_spots, holds, optimal_plan, solved, steps_after
from robocog.agent.symbolic.search import Cost, Found, Problem, astar
from robocog.agent.symbolic.world import Action, SceneNames, Spot, Where

__all__ = [
    "Action",
    "Cost",
    "Found",
    "Problem",
    "SceneNames",
    "Spot",
    "Where",
    "allowed_spots",
    "astar",
    "holds",
    "optimal_plan",
    "solved",
    "steps_after",
]
