"""The paper's tasks as fixed action sequences, run through the robot's tools (no MCP, no model).

`python -m robocog.server.demo` (`make world-demo`) runs T1 then T2 and prints every action's result and the
ground-truth verdicts.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS
from robocog.server.world.paper import T1_SEQUENCE, T2_SEQUENCE, Action, action_args
from robocog.server.world.tasks import evaluate, task_catalogue
from robocog.server.world.world import World
from robocog.shared.results import ActionResult

WORLD_TOOLS = {t.name: t for t in ROBOT_TOOLS if t.name in ("look_around", "move_to", "grab", "place")}


def perform(robot: RobotSession, action: Action) -> ActionResult:
    """Run one (tool name, *arguments) action through the session."""
    result: ActionResult = robot.call(WORLD_TOOLS[action[0]], **action_args(action))
    return result


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Run the paper's T1 and T2 as fixed action sequences.")
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--gui", action="store_true", help="open the PyBullet GUI (needs a display)")
    args = parser.parse_args(argv)
    tasks = task_catalogue()
    ok = True
    with World(seed=args.seed, gui=args.gui) as world:
        robot = RobotSession(SessionConfig(), world=world)
        for task_id, sequence in (("T1", T1_SEQUENCE), ("T2", T2_SEQUENCE)):
            task = tasks[task_id]
            print(f"[SYSTEM] Executing prompt: {task.prompt!r}")
            baseline = world.placements()
            start = time.perf_counter()
            for action in sequence:
                result = perform(robot, action)
                call = f"{action[0]}({', '.join(repr(a) for a in action[1:])})"
                print(f"[TOOL] {call}")
                print(f"[TOOL-RESPONSE] {result.status}: {result.message}")
            verdict = evaluate(task, world.placements(), baseline)
            elapsed = time.perf_counter() - start
            print(f"[SYSTEM] Ground truth for {task_id}: {'success' if verdict.success else 'failure'}")
            for v in verdict.objects:
                print(f"         {'ok ' if v.ok else 'NOT'} {v.reason}")
            print(f"[SYSTEM] {len(sequence)} actions in {elapsed:.3f} s wall, {world.steps} physics steps so far")
            print("---")
            ok = ok and verdict.success
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
