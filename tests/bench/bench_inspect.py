"""Figures: one T1 episode under Inspect (robocog.inspect, Inspect's mockllm replaying the planner's
tool calls) against the same episode under `robocog run T1 --model scripted/planner`.

Both run as a fresh process (interpreter, imports, a new `robocog-server` over stdio), so the
difference is what Inspect adds: its eval machinery, react(), its MCP client and the log it writes.
The planner runs first; its trace gives the tool calls the mock model replays, so both episodes make
the same calls. `inspect.eval_s` is the `eval()` call alone, inside the Inspect process.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

BIN = Path(sys.executable).parent

#: The Inspect side, run in its own process: argv[1] the planner's calls (JSON), argv[2] the log dir.
INSPECT_EPISODE = """
import json, sys, time
from inspect_ai import eval
from inspect_ai.model import ModelOutput, get_model
from robocog.inspect import t1
calls = json.loads(sys.argv[1])
outputs = [ModelOutput.for_tool_call(model="mockllm/model", tool_name=n, tool_arguments=a) for n, a in calls]
start = time.perf_counter()
[log] = eval(t1(), model=get_model("mockllm/model", custom_outputs=outputs), log_dir=sys.argv[2], display="none")
took = time.perf_counter() - start
score = log.samples[0].scores["robocog_verdict"]
print(json.dumps({"eval_s": took, "status": log.status, "success": score.value["success"]}))
"""


def planner_episode(work: Path) -> tuple[float, list[tuple[str, dict[str, Any]]]]:
    """`robocog run T1 --model scripted/planner`: wall seconds and the tool calls it made."""
    trace = work / "planner.jsonl"
    data = ["--data-dir", str(work / "planner-data")]
    start = time.perf_counter()
    done = subprocess.run(
        [str(BIN / "robocog"), "run", "T1", "--model", "scripted/planner", "--quiet", *data, "--trace", str(trace)],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"robocog run failed: {done.stdout}{done.stderr}")
    events = [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines() if line.strip()]
    calls = [(e["name"], e["arguments"] or {}) for e in events if e.get("type") == "tool_call"]
    return wall, calls


def inspect_episode(work: Path, calls: list[tuple[str, dict[str, Any]]]) -> tuple[float, dict[str, Any]]:
    """The same calls under Inspect: wall seconds and what the child reported."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", INSPECT_EPISODE, json.dumps(calls), str(work / "logs")],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"the Inspect episode failed: {done.stderr[-2000:]}")
    return wall, json.loads(done.stdout.strip().splitlines()[-1])


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="bench-inspect-") as tmp:
        work = Path(tmp)
        planner_wall, calls = planner_episode(work)
        inspect_wall, child = inspect_episode(work, calls)
    if child["status"] != "success" or child["success"] != 1.0:
        raise RuntimeError(f"the Inspect episode did not succeed: {child}")
    return {
        "inspect.t1_tool_calls": len(calls),
        "inspect.robocog_run_wall_s": round(planner_wall, 2),
        "inspect.inspect_wall_s": round(inspect_wall, 2),
        "inspect.eval_s": round(child["eval_s"], 2),
        "inspect.overhead_ratio": round(inspect_wall / planner_wall, 2),
    }
