"""`robocog bench`: how fast a robot server answers an agent, measured from the client's side.

It runs one task several times against a server (spawned, or a running one with `--url`; either
way the eval profile, for `reset_world` and `check_task`) and reports the episode's wall time,
each tool's latency and the model calls' own time, with the ground-truth success of every run.
"""

from __future__ import annotations

import statistics
import time
from collections import defaultdict
from typing import Any

from robocog.agent.client.connection import ServerSpec, connect
from robocog.agent.client.loop import run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.controls import EvalControls, mcp_call
from robocog.shared.errors import ConfigError, ModelServiceError, ServerConnectionError
from robocog.shared.trace import ModelTurn, ToolResult


def _quantile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


async def bench(spec: ServerSpec, settings: AgentSettings, task_id: str, runs: int) -> dict[str, Any]:
    """Run `task_id` `runs` times from a fresh world; the figures as a flat dict."""
    start = time.perf_counter()
    async with connect(spec) as robot:
        connected = time.perf_counter() - start
        names = {t.name for t in robot.tools}
        if not {"reset_world", "check_task"} <= names:
            raise ConfigError(
                "robocog bench needs a server started with --profile eval (for reset_world and check_task)"
            )
        prompt = robot.tasks.get(task_id)
        if prompt is None:
            raise ConfigError(f"the server has no task {task_id!r}; it has {', '.join(robot.tasks) or 'none'}")
        await robot.client.call_tool("look_around", {})  # the world is built
        controls = EvalControls(mcp_call(robot.client, ServerConnectionError))
        episodes: list[float] = []
        model_ms: list[float] = []
        tools: dict[str, list[float]] = defaultdict(list)
        successes = 0
        calls = 0
        for _ in range(runs):
            await controls.clear_memory()
            await controls.reset_world()
            trace = Trace()
            result = await run_episode(
                robot.client, prompt, settings, trace, system_prompt=robot.system_prompt, tools=robot.tools
            )
            if result.error:
                raise ModelServiceError(result.error)
            verdict = await controls.check_task(task_id)
            successes += verdict.success
            calls = result.tool_calls
            turns = [e for e in trace.events if isinstance(e, ModelTurn)]
            results = [e for e in trace.events if isinstance(e, ToolResult)]
            if turns and results:
                episodes.append(results[-1].t - turns[0].t + turns[0].latency_s)
            model_ms += [e.latency_s * 1e3 for e in turns]
            for e in results:
                tools[e.name].append(e.latency_s * 1e3)
    out: dict[str, Any] = {
        "bench.task": task_id,
        "bench.model": settings.model,
        "bench.server": spec.label,
        "bench.runs": runs,
        "bench.true_success_rate": successes / runs,
        "bench.tool_calls": calls,
        "bench.connect_s": round(connected, 3),
        "bench.episode_median_s": round(statistics.median(episodes), 4),
        "bench.episode_min_s": round(min(episodes), 4),
        "bench.model_call_p50_ms": round(_quantile(model_ms, 0.5), 3),
    }
    for name, values in sorted(tools.items()):
        out[f"bench.tool.{name}.p50_ms"] = round(_quantile(values, 0.5), 3)
        out[f"bench.tool.{name}.p95_ms"] = round(_quantile(values, 0.95), 3)
    return out
