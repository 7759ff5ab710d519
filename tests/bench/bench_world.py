"""Benchmark of the simulated world (not a pytest module).

Run: ``.venv/bin/python tests/bench/bench_world.py``. Targets (reported, not asserted):
T1 sequence median <= 0.25 s, build + reset median <= 0.3 s, episode / bare-step wall ratio <= 1.5.
Furniture (kitchen_plus): open and close of each container in-process, with their physics steps.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS, furniture, move_to
from robocog.server.tools.base import Tool
from robocog.server.world.world import World
from robocog.shared.results import ActionResult

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import T1_SEQUENCE, T2_SEQUENCE, Action, action_args

BUILD_RUNS = 5
RESET_RUNS = 5
T1_RUNS = 7
T2_RUNS = 5
BARE_RUNS = 5
FURNITURE_RUNS = 5

TARGET_T1_S = 0.25
TARGET_BUILD_RESET_S = 0.3
TARGET_STEP_RATIO = 1.5


def _timed(fn: Callable[[], object]) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _p90(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(0.9 * (len(ordered) - 1)))]


def _check(results: list, what: str) -> None:
    failed = [r.message for r in results if r.status != "success"]
    if failed:
        raise RuntimeError(f"{what}: {len(failed)} action(s) failed: {failed}")


TOOLS: dict[str, Tool[Any]] = {t.name: t for t in ROBOT_TOOLS}


def run_sequence(robot: RobotSession, actions: Sequence[Action]) -> list[ActionResult]:
    """The actions through the tools, as the server runs them (minus MCP)."""
    calls: list[tuple[Tool[Any], dict[str, Any]]] = [(TOOLS[a[0]], action_args(a)) for a in actions]
    return [robot.call(tool, **arguments) for tool, arguments in calls]


def _build_and_reset() -> World:
    world = World()
    world.reset()
    return world


def _measure() -> dict[str, float | int | bool]:
    out: dict[str, float | int | bool] = {}

    # Construction (+ its reset).
    build: list[float] = []
    for _ in range(BUILD_RUNS):
        start = time.perf_counter()
        w = _build_and_reset()
        build.append(time.perf_counter() - start)
        w.close()
    out["world.build_reset_s"] = round(statistics.median(build), 4)
    out["world.build_reset_min_s"] = round(min(build), 4)

    world = World()
    robot = RobotSession(SessionConfig(), world=world)
    try:
        # reset() of a world that has run an episode (the usual case between episodes).
        resets: list[float] = []
        for _ in range(RESET_RUNS):
            world.reset()
            robot.call(move_to.TOOL, location="Kitchen Shelf")
            resets.append(_timed(world.reset))
        out["world.reset_s"] = round(statistics.median(resets), 5)

        # T1 from the paper's start.
        t1: list[float] = []
        t1_steps = 0
        for _ in range(T1_RUNS):
            world.reset()
            start = time.perf_counter()
            results = run_sequence(robot, T1_SEQUENCE)
            t1.append(time.perf_counter() - start)
            _check(results, "T1")
            t1_steps = world.steps
        t1_median = statistics.median(t1)
        out["world.t1_sequence_s"] = round(t1_median, 4)
        out["world.t1_sequence_p90_s"] = round(_p90(t1), 4)
        out["world.t1_sequence_min_s"] = round(min(t1), 4)
        out["world.t1_steps"] = t1_steps
        out["world.t1_actions"] = len(T1_SEQUENCE)

        # The same number of bare physics steps from T1's start state: what the episode costs
        # beyond stepping a resting world (IK, motions, placements, bodies kept awake).
        bare: list[float] = []
        for _ in range(BARE_RUNS):
            world.reset()
            step = world.client.stepSimulation
            start = time.perf_counter()
            for _ in range(t1_steps):
                step()
            bare.append(time.perf_counter() - start)
        bare_median = statistics.median(bare)
        out["world.bare_step_us"] = round(bare_median / t1_steps * 1e6, 2)
        # Against a resting world, whose bodies sleep: physics that the episode itself makes dearer
        # (a carried object, bodies woken by placing) counts against the action layer here.
        out["world.step_ratio_vs_resting"] = round(t1_median / bare_median, 3)

        # Where an episode's time goes: the share spent inside stepSimulation, and its cost per step.
        world.reset()
        sim = world.sim  # reset builds a new Sim: instrument the one the episode runs on
        stepping = sim._step_simulation
        in_step = [0.0]

        def timed_step() -> None:
            start = time.perf_counter()
            stepping()
            in_step[0] += time.perf_counter() - start

        sim._step_simulation = timed_step
        try:
            start = time.perf_counter()
            _check(run_sequence(robot, T1_SEQUENCE), "T1 (instrumented)")
            total = time.perf_counter() - start
        finally:
            sim._step_simulation = stepping
        out["world.t1_step_share"] = round(in_step[0] / total, 3)
        out["world.t1_episode_step_us"] = round(in_step[0] / world.steps * 1e6, 2)
        # The episode's wall time over the time its own stepSimulation calls took: what the action
        # layer (IK, trajectories, ground truth, results) costs beyond the physics it runs.
        out["world.step_ratio"] = round(total / in_step[0], 3)

        # T2 after T1 in the same world.
        t2: list[float] = []
        t2_steps = 0
        for _ in range(T2_RUNS):
            world.reset()
            _check(run_sequence(robot, T1_SEQUENCE), "T1 before T2")
            before = world.steps
            start = time.perf_counter()
            results = run_sequence(robot, T2_SEQUENCE)
            t2.append(time.perf_counter() - start)
            _check(results, "T2")
            t2_steps = world.steps - before
        out["world.t2_sequence_s"] = round(statistics.median(t2), 4)
        out["world.t2_sequence_min_s"] = round(min(t2), 4)
        out["world.t2_steps"] = t2_steps
    finally:
        world.close()

    out["world.target_t1_s"] = TARGET_T1_S
    out["world.target_build_reset_s"] = TARGET_BUILD_RESET_S
    out["world.target_step_ratio"] = TARGET_STEP_RATIO
    out["world.t1_within_target"] = bool(out["world.t1_sequence_s"] <= TARGET_T1_S)
    out["world.build_reset_within_target"] = bool(out["world.build_reset_s"] <= TARGET_BUILD_RESET_S)
    out["world.step_ratio_within_target"] = bool(out["world.step_ratio"] <= TARGET_STEP_RATIO)
    return out


def _measure_furniture() -> dict[str, float | int | bool]:
    """open and close of each of kitchen_plus's containers through the tools (in-process, no MCP): the
    median wall time and the physics steps of each action, the robot already at the container."""
    out: dict[str, float | int | bool] = {}
    world = World("kitchen_plus")
    try:
        robot = RobotSession(SessionConfig(), world=world)
        for name in world.container_names:
            times: dict[str, list[float]] = {"open": [], "close": []}
            steps: dict[str, int] = {}
            for _ in range(FURNITURE_RUNS):
                world.reset()
                robot.call(move_to.TOOL, location=world.scene.container(name).location)
                for verb, tool in (("open", furniture.OPEN), ("close", furniture.CLOSE)):
                    start = time.perf_counter()
                    result = robot.call(tool, furniture=name)
                    times[verb].append(time.perf_counter() - start)
                    if result.outcome not in ("opened", "closed"):
                        raise RuntimeError(f"{verb} {name}: {result.message}")
                    steps[verb] = result.steps
            for verb in ("open", "close"):
                out[f"world.{verb}_{name}_s"] = round(statistics.median(times[verb]), 4)
                out[f"world.{verb}_{name}_steps"] = steps[verb]
    finally:
        world.close()
    return out


def run() -> dict[str, float | int | bool]:
    """Measure the world; a flat dict of rounded numbers (and whether each target is met)."""
    return {**_measure(), **_measure_furniture()}


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
