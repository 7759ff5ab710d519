"""Client figures: `robocog run T1 --model scripted/planner` as a whole process, and its episode."""

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
    return {
        "client.run_t1_process_s": round(statistics.median(walls), 3),
        "client.run_t1_process_min_s": round(min(walls), 3),
        "client.episode_first_turn_to_end_task_s": round(statistics.median(episodes), 3),
        "client.target_process_s": 6.0,
        "client.target_episode_s": 0.6,
    }


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
