"""The paper's tasks as fixed action sequences, run directly on the world (no MCP, no model).

`python -m robocog.server.world.demo` runs T1 then T2 and prints every action's result and the
ground-truth verdicts. The same sequences serve the tests and the benchmark.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from robocog.server.world.tasks import evaluate, task_catalogue
from robocog.server.world.world import World
from robocog.shared.results import ActionResult

Action = tuple[str, ...]

#: T1: look, then cube to the top layer, box to the middle, mug to the bottom (12 actions).
T1_SEQUENCE: tuple[Action, ...] = (
    ("look_around",),
    ("grab", "cube"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "top"),
    ("move_to", "Living Room"),
    ("grab", "box"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "middle"),
    ("move_to", "Kitchen Table"),
    ("grab", "mug"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "bottom"),
)

#: T2 after T1: park the cube on the kitchen floor, move the mug up, bring the cube down.
T2_SEQUENCE: tuple[Action, ...] = (
    ("grab", "cube"),
    ("move_to", "Kitchen Area Left"),
    ("place", "Kitchen Area Left", "floor"),
    ("move_to", "Kitchen Shelf"),
    ("grab", "mug"),
    ("place", "Kitchen Shelf", "top"),
    ("move_to", "Kitchen Area Left"),
    ("grab", "cube"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "bottom"),
)


def perform(world: World, action: Action) -> ActionResult:
    """Run one (name, *args) action on the world."""
    name, *args = action
    if name not in ("look_around", "move_to", "grab", "place"):
        raise ValueError(f"unknown action {name!r}")
    result: ActionResult = getattr(world, name)(*args)
    return result


def run_sequence(world: World, actions: Sequence[Action]) -> list[ActionResult]:
    """Run the actions in order; returns every result (failures included)."""
    return [perform(world, a) for a in actions]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Run the paper's T1 and T2 as fixed action sequences.")
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--gui", action="store_true", help="open the PyBullet GUI (needs a display)")
    args = parser.parse_args(argv)
    tasks = task_catalogue()
    ok = True
    with World(seed=args.seed, gui=args.gui) as world:
        for task_id, sequence in (("T1", T1_SEQUENCE), ("T2", T2_SEQUENCE)):
            task = tasks[task_id]
            print(f"[SYSTEM] Executing prompt: {task.prompt!r}")
            baseline = world.placements()
            start = time.perf_counter()
            for action in sequence:
                result = perform(world, action)
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
