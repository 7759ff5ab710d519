"""robocog-v2.1 at full size (issue 42): the information-fair oracle on every instance of both splits,
what the splits hold, the three orders of calls on every recovery instance, and the robocog-v2
instances whose v2.1 counterpart changes, and why.

Figures: per family, the oracle's success (feasible) or honest failure (infeasible) and its robot
actions over the optimum (fully observed and partially observed apart: a search explores, and its
optimum is the one with the whole house in view); per family, plan lengths (fewest / median / most)
and the share under partial observation; per order of calls (the planner, `verbose`, `lean`), the share
of recovery instances in which it met the perturbation before its goal, noticed it and met its bar;
per reason, the robocog-v2 instances v2.1 changes (`changed_in_v2_1`).
"""

from __future__ import annotations

import asyncio
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from robocog.agent.analysis.recovery import met_before_goal, noticed
from robocog.agent.client.connection import Robot, ServerSpec, connect
from robocog.agent.suitegen import stats
from robocog.agent.symbolic import SceneNames
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import Instance, load_split, load_suite
from robocog.shared.trace import TraceEvent

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_suite import Outcome, _call, _episode, run_split  # type: ignore[import-not-found]  # a sibling

SUITE = "robocog-v2.1"
ORDERS = ("planner", "verbose", "lean")
ROBOT_ACTIONS = {"move_to", "grab", "place", "open", "close"}


async def traced_instance(
    robot: Robot, instance: Instance, model: str = "scripted/planner", *, suite: str = SUITE
) -> tuple[Outcome, list[TraceEvent]]:
    """Run `instance` (its earlier tasks first) with `model`; its outcome and its own episode's trace."""
    from robocog.shared.trace import ToolCall

    reset = {"instance": instance.id, "suite": suite, "memory_namespace": f"orders-{instance.id}"}
    await _call(robot, "reset_world", reset)
    await _call(robot, "clear_memory", {})
    for i, step in enumerate(instance.prelude, 1):
        await _call(robot, "begin_task", {"task_id": f"{instance.id}-pre{i}"})
        await _episode(robot, step.prompt, model, {})
    await _call(robot, "begin_task", {"task_id": instance.id})
    result, trace = await _episode(robot, instance.prompt, model, {})
    verdict = await _call(robot, "check_task", {"task_id": instance.id})
    actions = sum(1 for e in trace.events if isinstance(e, ToolCall) and e.name in ROBOT_ACTIONS)
    outcome = Outcome(
        instance, result.believed_success, bool(verdict["success"]), actions, result.tool_calls, result.summary
    )
    return outcome, list(trace.events)


def oracle(instances: list[Instance], workers: int = 2) -> dict[str, Any]:
    """The planner on every instance: per family its bar and its actions over the optimum."""
    started = time.perf_counter()
    outcomes: list[Outcome] = asyncio.run(run_split(instances, workers, suite=SUITE))
    out: dict[str, Any] = {"suite_v21.oracle.instances": len(outcomes)}
    out["suite_v21.oracle.wall_2_workers_s"] = round(time.perf_counter() - started, 1)
    by_family: dict[str, list[Outcome]] = defaultdict(list)
    for o in outcomes:
        by_family[o.instance.family].append(o)
    for family, rows in by_family.items():
        feasible = [o for o in rows if o.instance.feasible]
        infeasible = [o for o in rows if not o.instance.feasible]
        if feasible:
            out[f"suite_v21.oracle.{family}.success"] = round(sum(o.ok for o in feasible) / len(feasible), 3)
        if infeasible:
            out[f"suite_v21.oracle.{family}.honest_failure"] = round(sum(o.ok for o in infeasible) / len(infeasible), 3)
        for seen in ("full", "partial"):
            part = [o for o in rows if (o.instance.observe is None) == (seen == "full")]
            optimum = sum(o.instance.optimal_steps for o in part)
            if optimum:
                out[f"suite_v21.oracle.{family}.actions_over_optimal.{seen}"] = round(
                    sum(o.robot_actions for o in part) / optimum, 3
                )
    feasible = [o for o in outcomes if o.instance.feasible]
    infeasible = [o for o in outcomes if not o.instance.feasible]
    out["suite_v21.oracle.feasible_success"] = round(sum(o.ok for o in feasible) / max(1, len(feasible)), 3)
    out["suite_v21.oracle.infeasible_honest_failure"] = round(
        sum(o.ok for o in infeasible) / max(1, len(infeasible)), 3
    )
    out["suite_v21.oracle.failed"] = [f"{o.instance.id}: {o.summary}" for o in outcomes if not o.ok]
    return out


def contents(instances: list[Instance]) -> dict[str, Any]:
    """Per family: instances, plan lengths of the feasible ones, the share under partial observation."""
    out: dict[str, Any] = {"suite_v21.instances": len(instances)}
    partial = [i for i in instances if i.observe is not None]
    out["suite_v21.partial_observation_share"] = round(len(partial) / len(instances), 3)
    out["suite_v21.partial_observation_families"] = len({i.family for i in partial})
    for family, lengths in stats.plan_lengths(instances).items():
        out[f"suite_v21.plan.{family}"] = f"{lengths.low} / {lengths.median:g} / {lengths.high}"
    for family, n in stats.per_family(instances).items():
        part = sum(i.observe is not None for i in instances if i.family == family)
        out[f"suite_v21.family.{family}.partial_share"] = round(part / n, 3)
    out["suite_v21.ungraspable"] = sum(i.variant == "ungraspable" for i in instances)
    return out


def orders(instances: list[Instance]) -> dict[str, Any]:
    """Each order of calls on every recovery instance: met the perturbation before its goal, noticed
    it, met its bar (success, or an honest failure where the task cannot be done)."""
    recovery = [i for i in instances if i.family == "recovery"]
    out: dict[str, Any] = {"suite_v21.orders.recovery_instances": len(recovery)}

    async def run(model: str) -> list[tuple[Outcome, list[TraceEvent]]]:
        with tempfile.TemporaryDirectory() as tmp:
            spec = ServerSpec(extra_args=["--profile", "eval", "--data-dir", tmp])
            async with connect(spec) as robot:
                return [await traced_instance(robot, i, f"scripted/{model}") for i in recovery]

    for model in ORDERS:
        runs = asyncio.run(run(model))
        n = max(1, len(runs))
        out[f"suite_v21.orders.{model}.met_before_goal"] = round(sum(met_before_goal(e) for _, e in runs) / n, 3)
        out[f"suite_v21.orders.{model}.noticed"] = round(sum(bool(noticed(e)) for _, e in runs) / n, 3)
        out[f"suite_v21.orders.{model}.bar"] = round(sum(o.ok for o, _ in runs) / n, 3)
        out[f"suite_v21.orders.{model}.missed"] = [o.instance.id for o, e in runs if not met_before_goal(e)]
    return out


def changed_in_v2_1() -> dict[str, Any]:
    """The robocog-v2 instances v2.1's rules change, by reason (an instance may have several)."""
    from robocog.agent.families.referring import seen_words
    from robocog.agent.suitegen.generator import furnished_room, starts_where_sent

    reasons: dict[str, list[str]] = defaultdict(list)
    for split in ("dev", "test"):
        for i in load_split("robocog-v2", split):
            world = SceneNames(load_scene(scene_path(i.scene)))
            start: dict[str, tuple[str, str] | None] = {o: (s.location, s.position) for o, s in i.start.items()}
            if any(p.kind != "slip" for p in i.perturbations):
                reasons["perturbation_counted_calls"].append(i.id)
            if i.family == "referring" and "description" in i.parameters:
                words = set(i.parameters["description"].lower().split()) - {"the", "a", "an", "thing", "something"}
                if [o for o, said in seen_words(world).items() if words and words <= said] != [i.parameters["item"]]:
                    reasons["description_not_in_what_the_tools_say"].append(i.id)
            rooms = [v for k, v in i.parameters.items() if k.endswith("location") and isinstance(v, str)]
            if any(furnished_room(world, v) for v in rooms if v in {loc.name for loc in world.scene.locations}):
                reasons["room_target_means_its_floor"].append(i.id)
            if not i.prelude and starts_where_sent(world, i.success, start):
                reasons["item_starts_where_sent"].append(i.id)
            if i.variant == "ungraspable":
                reasons["infeasible_optimum_counts_finding_out"].append(i.id)
            if i.family in ("bring", "put_away", "rearrange", "memory") or i.variant == "moved":
                reasons["now_under_partial_observation"].append(i.id)
    out: dict[str, Any] = {f"suite_v21.changed_from_v2.{r}": len(ids) for r, ids in reasons.items()}
    out["suite_v21.changed_from_v2.ids"] = {
        r: ids for r, ids in reasons.items() if r != "now_under_partial_observation"
    }
    return out


def run() -> dict[str, Any]:
    suite = load_suite(SUITE)
    everything = [i for split in suite.splits for i in load_split(SUITE, split)]
    figures = contents(everything)
    figures |= changed_in_v2_1()
    figures |= orders(everything)
    figures |= oracle(everything)
    return figures


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=1))
