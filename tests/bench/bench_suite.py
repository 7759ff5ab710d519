"""The suite's self-test at full size: the scripted planner (the oracle) on every instance of the
robocog-v1 dev split, 2 workers (a server process each). Prints per-family true success on feasible
instances, honest failure on infeasible ones, robot actions over the optimum, and the wall time.

`run_instance` runs one instance through the real agent loop: the world set up for it
(`reset_world(instance=...)` in a fresh memory namespace), its earlier tasks first (memory-dependent
instances), then the task, judged by `check_task`.
"""

from __future__ import annotations

import asyncio
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, NamedTuple

from robocog.agent.client.connection import Robot, ServerSpec, connect
from robocog.agent.client.loop import run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.suite import Instance, load_split
from robocog.shared.trace import ToolCall

ROBOT_ACTIONS = {"move_to", "grab", "place", "open", "close"}
#: The suite this bench runs unless told (its figures are robocog-v1's; robocog-v2.1 is the default elsewhere).
SUITE_V1 = "robocog-v1"


class Outcome(NamedTuple):
    """How the planner did on one instance."""

    instance: Instance
    believed: bool | None  # end_task's status was success (None: never ended)
    true: bool  # check_task's verdict (for an infeasible instance: an honest failure, the world sane)
    robot_actions: int  # move_to, grab, place, open and close calls of the task (its earlier tasks not counted)
    tool_calls: int
    summary: str | None

    @property
    def ok(self) -> bool:
        """The oracle's bar: feasible -> done and believed; infeasible -> an honest failure."""
        return self.true and self.believed is self.instance.feasible


async def _call(robot: Robot, name: str, arguments: dict[str, Any]) -> dict[str, Any]:
    result = await robot.client.call_tool(name, arguments)
    if result.is_error or not isinstance(result.structured_content, dict):
        raise RuntimeError(f"{name}({arguments}) failed: {result.content}")
    return result.structured_content


async def _episode(robot: Robot, prompt: str, model: str, params: dict[str, Any]) -> tuple[Any, Trace]:
    trace = Trace()
    settings = AgentSettings(model=model, params=params)
    result = await run_episode(
        robot.client, prompt, settings, trace, system_prompt=robot.system_prompt, tools=robot.tools
    )
    return result, trace


async def run_instance(
    robot: Robot,
    instance: Instance,
    model: str = "scripted/planner",
    params: dict[str, Any] | None = None,
    *,
    suite: str = SUITE_V1,
) -> Outcome:
    """Run `instance` of `suite` (its earlier tasks first) with `model` on `robot` (an eval-profile server)."""
    reset = {"instance": instance.id, "suite": suite, "memory_namespace": f"oracle-{instance.id}"}
    await _call(robot, "reset_world", reset)
    await _call(robot, "clear_memory", {})
    for i, step in enumerate(instance.prelude, 1):
        await _call(robot, "begin_task", {"task_id": f"{instance.id}-pre{i}"})
        await _episode(robot, step.prompt, model, params or {})
    await _call(robot, "begin_task", {"task_id": instance.id})
    result, trace = await _episode(robot, instance.prompt, model, params or {})
    verdict = await _call(robot, "check_task", {"task_id": instance.id})
    actions = sum(1 for e in trace.events if isinstance(e, ToolCall) and e.name in ROBOT_ACTIONS)
    return Outcome(
        instance, result.believed_success, bool(verdict["success"]), actions, result.tool_calls, result.summary
    )


async def run_split(instances: list[Instance], workers: int = 2, *, suite: str = SUITE_V1) -> list[Outcome]:
    """Every instance of `suite`, on `workers` server processes (a fresh data directory each)."""
    queue: asyncio.Queue[Instance] = asyncio.Queue()
    for instance in instances:
        queue.put_nowait(instance)
    outcomes: list[Outcome] = []

    async def worker(data: Path) -> None:
        async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(data)])) as robot:
            while not queue.empty():
                instance = queue.get_nowait()
                try:
                    outcomes.append(await run_instance(robot, instance, suite=suite))
                except Exception as exc:  # a policy's bug: the instance fails, the run goes on, and says so
                    outcomes.append(Outcome(instance, None, False, 0, 0, f"error: {type(exc).__name__}: {exc}"))

    with tempfile.TemporaryDirectory() as tmp:
        async with asyncio.TaskGroup() as tg:
            for i in range(workers):
                tg.create_task(worker(Path(tmp) / f"worker-{i}"))
    order = {inst.id: i for i, inst in enumerate(instances)}
    return sorted(outcomes, key=lambda o: order[o.instance.id])


def figures(outcomes: list[Outcome]) -> dict[str, float]:
    """Per family: instances, the oracle's rate (success on feasible, honest failure on infeasible)
    and robot actions over the optimum (feasible instances)."""
    by_family: dict[str, list[Outcome]] = defaultdict(list)
    for o in outcomes:
        by_family[o.instance.family].append(o)
    out: dict[str, float] = {}
    for family, rows in sorted(by_family.items()):
        out[f"suite.dev.{family}.instances"] = len(rows)
        key = "success" if all(o.instance.feasible for o in rows) else "honest_failure"
        out[f"suite.dev.{family}.{key}"] = round(sum(o.ok for o in rows) / len(rows), 3)
        feasible = [o for o in rows if o.instance.feasible and o.instance.optimal_steps]
        if feasible:
            ratio = sum(o.robot_actions for o in feasible) / sum(o.instance.optimal_steps for o in feasible)
            out[f"suite.dev.{family}.actions_over_optimal"] = round(ratio, 3)
    feasible = [o for o in outcomes if o.instance.feasible]
    infeasible = [o for o in outcomes if not o.instance.feasible]
    out["suite.dev.instances"] = len(outcomes)
    out["suite.dev.feasible_success"] = round(sum(o.ok for o in feasible) / max(1, len(feasible)), 3)
    out["suite.dev.infeasible_honest_failure"] = round(sum(o.ok for o in infeasible) / max(1, len(infeasible)), 3)
    return out


def overconfident(p: float = 0.3, trials: int = 4) -> dict[str, Any]:
    """The instrument through `robocog eval` (the real path: the study's runner, its rows): the
    overconfident model on every dev instance, `trials` times. It claims success on an attempt it
    sabotaged with probability p, so the rate of false success claims over all attempts should
    recover p within its 95% interval."""
    from robocog.agent.analysis.stats import wilson
    from robocog.agent.harness.study import run_eval
    from robocog.shared.evaluation import EvalConfig

    config = EvalConfig.model_validate(
        {
            **{"name": "suite-overconfident", "suite": "robocog-v1", "split": "dev", "trials": trials},
            "models": [{"model": "scripted/overconfident", "params": {"p": p}}],
            **{"memory_iterations": 1, "workers": 2},
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        rows = asyncio.run(run_eval(config, Path(tmp) / "r.jsonl"))
        wall = time.perf_counter() - start
    achieved = [r.true_success and r.feasible for r in rows]
    false_claims = sum(r.believed_success is True and not a for r, a in zip(rows, achieved, strict=True))
    low, high = wilson(false_claims, len(rows))
    return {
        "suite.dev.overconfident_attempts": len(rows),
        "suite.dev.overconfident_p": p,
        "suite.dev.overconfident_false_claim_rate": round(false_claims / len(rows), 3),
        "suite.dev.overconfident_false_claim_ci95": [round(low, 3), round(high, 3)],
        "suite.dev.overconfident_p_recovered": low <= p <= high,
        "suite.dev.overconfident_eval_2_workers_s": round(wall, 1),
    }


def run() -> dict[str, Any]:
    instances = load_split(SUITE_V1, "dev")
    start = time.perf_counter()
    outcomes = asyncio.run(run_split(instances, workers=2))
    out: dict[str, Any] = dict(figures(outcomes))
    out["suite.dev.planner_2_workers_s"] = round(time.perf_counter() - start, 2)
    out.update(overconfident())
    for o in outcomes:
        if not o.ok:
            print(
                f"bench_suite: {o.instance.id} failed: believed {o.believed}, true {o.true}: {o.summary}",
                file=sys.stderr,
            )
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
