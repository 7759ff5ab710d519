"""What an attempt costs beyond its physics: the marginal CPU of one scripted T1 attempt in a study
(harness and server processes together) divided by the CPU of the same twelve actions run
in-process on a `World`, both measured in the same run.

The marginal CPU is that of a study of `1 + EXTRA` trials minus that of a study of 1 (so the start-up
of the harness and its servers cancels), divided by `EXTRA`, averaged over `ROUNDS` measurements
(alternating with the other install's); each study runs `robocog eval` as a process, and its CPU is
that of the process and every child it reaped (its servers), from `RUSAGE_CHILDREN`. Over stdio (a
server process per worker) and on a fleet (HTTP).

`ROBOCOG_BENCH_AGAINST=/path/to/other/.venv/bin` measures another install's studies too (the previous
release, say), alternating with this one's, against the same physics-only figure.

    python tests/bench/bench_overhead.py [--against /tmp/before/.venv/bin] [--extra 10]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from robocog.server.config import SessionConfig
from robocog.server.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS
from robocog.server.world.world import World

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import T1_SEQUENCE, action_args, installed_env

EXTRA = 10
#: Rounds, each measuring the physics and every install's marginal CPU (see `measure`).
ROUNDS = 3
PHYSICS_RUNS = 7
ENV = installed_env()


def physics_cpu_s() -> float:
    """The median CPU of T1's twelve actions on an in-process world, from the paper's start."""
    tools = {t.name: t for t in ROBOT_TOOLS}
    world = World()
    robot = RobotSession(SessionConfig(), world=world)
    runs: list[float] = []
    try:
        for _ in range(PHYSICS_RUNS):
            world.reset()
            start = time.process_time()
            for action in T1_SEQUENCE:
                result = robot.call(tools[action[0]], **action_args(action))
                assert result.status == "success", result.message
            runs.append(time.process_time() - start)
    finally:
        world.close()
    return statistics.median(runs)


def _config(path: Path, trials: int, isolation: str) -> Path:
    config = {
        "name": "overhead",
        "models": [{"model": "scripted/planner"}],
        "tasks": ["T1"],
        "trials": trials,
        "memory_iterations": 1,
        "seed": 0,
        "workers": 1,
        "isolation": isolation,
    }
    if isolation == "fleet":
        config["fleet_processes"] = 1
    path.write_text(json.dumps(config), encoding="utf-8")  # YAML reads JSON
    return path


def study_cpu_s(bin_dir: Path, trials: int, isolation: str) -> float:
    """CPU seconds of `robocog eval` on a study of `trials` T1 attempts, its servers included."""
    with tempfile.TemporaryDirectory() as tmp:
        config = _config(Path(tmp) / "study.yaml", trials, isolation)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        done = subprocess.run(
            [str(bin_dir / "robocog"), "eval", str(config), "--out", f"{tmp}/rows.jsonl", "--quiet"],
            capture_output=True,
            text=True,
            env={**ENV, "ROBOCOG_DATA_DIR": f"{tmp}/memory"},
            cwd=tmp,
            timeout=900,
        )
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise RuntimeError(f"{bin_dir}: robocog eval ({isolation}, {trials}) failed: {done.stderr[-800:]}")
        rows = [json.loads(line) for line in Path(f"{tmp}/rows.jsonl").read_text(encoding="utf-8").splitlines()]
        if len(rows) != trials or not all(r["true_success"] for r in rows):
            raise RuntimeError(f"{bin_dir}: the study did not succeed on every trial: {rows}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def marginal_cpu_s(bin_dir: Path, isolation: str, extra: int) -> float:
    study_cpu_s(bin_dir, 1, isolation)  # a warm-up: bytecode written, page cache filled, for both installs
    return (study_cpu_s(bin_dir, 1 + extra, isolation) - study_cpu_s(bin_dir, 1, isolation)) / extra


def measure(here: Path, against: Path | None, extra: int = EXTRA) -> dict[str, Any]:
    """Each round measures the physics-only CPU, then each install's marginal attempt on stdio and on
    a fleet, alternately: a ratio is an attempt over the physics of its own round (this machine's
    speed drifts by a third within minutes), and the figures are the rounds' means."""
    installs = [("", here)] + ([("against.", against)] if against is not None else [])
    physics: list[float] = []
    attempts: dict[str, list[float]] = {}
    ratios: dict[str, list[float]] = {}
    for _ in range(ROUNDS):
        physics.append(physics_cpu_s())
        for isolation, name in (("process", "stdio"), ("fleet", "fleet")):
            for prefix, bin_dir in installs:
                attempt = marginal_cpu_s(bin_dir, isolation, extra)
                attempts.setdefault(f"{prefix}{name}", []).append(attempt)
                ratios.setdefault(f"{prefix}{name}", []).append(attempt / physics[-1])
    out: dict[str, Any] = {
        "overhead.physics_cpu_s": round(statistics.mean(physics), 3),
        "overhead.physics_cpu_s_runs": [round(v, 3) for v in physics],
    }
    for key, values in attempts.items():
        out[f"overhead.{key}.attempt_cpu_s"] = round(statistics.mean(values), 3)
        out[f"overhead.{key}.attempt_cpu_s_runs"] = [round(v, 3) for v in values]
        out[f"overhead.{key}.ratio"] = round(statistics.mean(ratios[key]), 2)
        out[f"overhead.{key}.ratio_runs"] = [round(v, 2) for v in ratios[key]]
    out["overhead.physics_cpu_s_after"] = round(physics_cpu_s(), 3)  # the machine's drift over the run
    out["overhead.target_ratio"] = 1.5
    return out


def run() -> dict[str, Any]:
    against = os.environ.get("ROBOCOG_BENCH_AGAINST")
    return measure(Path(sys.executable).parent, Path(against) if against else None)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", type=Path, help="another install's bin directory")
    parser.add_argument("--extra", type=int, default=EXTRA, help="trials beyond the first in the larger study")
    args = parser.parse_args()
    print(json.dumps(measure(Path(sys.executable).parent, args.against, args.extra), indent=2))
