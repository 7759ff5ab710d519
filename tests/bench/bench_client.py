"""Client figures: `robocog run T1 --model scripted/planner` as a whole process, and its episode; and
the client's CPU per call over stdio, through the SDK's `Client` (robocog's path for a server a user
names) and through robocog's lean client (the servers a study starts itself), in alternating rounds
against servers of their own (`--per-call`, in a process of its own)."""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from robocog.shared.trace import ModelTurn, ToolResult, read_trace

RUNS = 5
#: Calls per client and tool in each of `ROUNDS` alternating rounds.
CALLS, ROUNDS = 200, 5


def _robocog() -> list[str]:
    script = Path(sys.executable).parent / "robocog"
    return [str(script)] if script.exists() else [sys.executable, "-m", "robocog.agent.cli"]


def run() -> dict[str, float]:
    walls: list[float] = []
    episodes: list[float] = []
    for i in range(RUNS):
        with tempfile.TemporaryDirectory() as tmp:
            trace = Path(tmp) / "trace.jsonl"
            start = time.perf_counter()
            done = subprocess.run(
                [
                    *_robocog(),
                    "run",
                    "T1",
                    "--model",
                    "scripted/planner",
                    "--data-dir",
                    f"{tmp}/memory",
                    "--trace",
                    str(trace),
                    "--quiet",
                ],
                capture_output=True,
                text=True,
                timeout=120,
            )
            walls.append(time.perf_counter() - start)
            if done.returncode != 0:
                raise RuntimeError(f"robocog run failed (run {i}): {done.stderr}")
            events = read_trace(trace)
            first = next(e for e in events if isinstance(e, ModelTurn))
            end = next(e for e in events if isinstance(e, ToolResult) and e.name == "end_task")
            episodes.append(end.t - first.t + first.latency_s)
    return _per_call_in_child() | {
        "client.run_t1_process_s": round(statistics.median(walls), 3),
        "client.run_t1_process_min_s": round(min(walls), 3),
        "client.episode_first_turn_to_end_task_s": round(statistics.median(episodes), 3),
        "client.target_process_s": 6.0,
        "client.target_episode_s": 0.6,
    }


async def _per_call() -> dict[str, float]:
    """The client's CPU per call of a no-op tool (`view_scratchpad`) and of `look_around`, through the
    SDK's `Client` and through the lean client, each against a `robocog-server` of its own."""
    from contextlib import AsyncExitStack

    from robocog.agent.client.connection import ServerSpec, connect

    spent: dict[tuple[str, str], float] = {}
    async with AsyncExitStack() as stack:
        clients = {}
        for way, lean in (("sdk", False), ("lean", True)):
            data = stack.enter_context(tempfile.TemporaryDirectory())
            spec = ServerSpec(extra_args=["--profile", "eval", "--data-dir", data], lean=lean)
            clients[way] = (await stack.enter_async_context(connect(spec))).client
            for _ in range(20):  # the world built, the first calls' caches warm
                await clients[way].call_tool("look_around", {})
        for _ in range(ROUNDS):
            for tool in ("view_scratchpad", "look_around"):
                for way, client in clients.items():
                    start = time.process_time()
                    for _ in range(CALLS):
                        await client.call_tool(tool, {})
                    spent[(way, tool)] = spent.get((way, tool), 0.0) + time.process_time() - start
    names = {"view_scratchpad": "noop", "look_around": "look_around"}
    return {
        f"client.stdio.{way}.{names[tool]}_cpu_ms_per_call": round(cpu / (CALLS * ROUNDS) * 1000, 3)
        for (way, tool), cpu in spent.items()
    }


def _per_call_in_child() -> dict[str, float]:
    """`_per_call` in a process of its own: `make bench` runs every bench in one process, and the threads
    an earlier bench left behind would count in this client's CPU."""
    done = subprocess.run(
        [sys.executable, __file__, "--per-call"], capture_output=True, text=True, check=True, timeout=600
    )
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


if __name__ == "__main__":
    if sys.argv[1:] == ["--per-call"]:
        import anyio

        print(json.dumps(anyio.run(_per_call)))
    else:
        print(json.dumps(run(), indent=2))
