"""Verified by replay (issue 47), as figures: the determinism matrix, replay time per attempt against
the attempt's own, and verifying a 400-attempt submission.

- Determinism: one study of robocog-v2.1 dev instances (every family, perturbations and earlier tasks
  among them) by the fault-injecting policy (`scripted/faulty`, rate 0.3: not the planner), run by
  `robocog eval` over stdio with 1 worker, over stdio with 2 workers and on a fleet
  (`isolation: fleet`, 2 workers); each attempt's verdict (true success, belief, tool calls, robot
  actions, perturbations, error taxonomy) compared across the three, and each results file replayed
  by `robocog submit verify`.
- Cost: per attempt, the wall time of its replay (from the replay record) against the attempt's own
  wall time (its row), and the CPU of the whole `robocog eval` against that of `robocog submit verify`
  (the processes and their servers, `getrusage` of the children), per attempt.
- Scale: the 440-attempt study of every robocog-v2.1 dev instance, packed by `robocog submit prepare`
  (its size) and verified (its wall time and CPU).

`python tests/bench/run.py --only replay [--record]`.
"""

from __future__ import annotations

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

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from robocog.agent.analysis.results_file import read_rows
from robocog.shared.evaluation import AttemptRow

INSTANCES = int(os.environ.get("BENCH_REPLAY_INSTANCES", "24"))
#: The scale study: every robocog-v2.1 dev instance once (440 attempts), which a submission must cover;
#: fewer (a quick look) verify the results file instead of a submission.
SCALE = int(os.environ.get("BENCH_REPLAY_SCALE_INSTANCES", "440"))
CLI = [sys.executable, "-m", "robocog.agent.cli"]
STUDY = """name: {name}
models:
  - {{model: scripted/faulty, label: faulty-0.3, params: {{rate: 0.3}}}}
suite: robocog-v2.1
split: dev
instances: {instances}
trials: {trials}
memory_iterations: 1
seed: 0
workers: {workers}
isolation: {isolation}
"""


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(command: list[str]) -> tuple[subprocess.CompletedProcess[str], float, float]:
    """Run `command`; its result, wall seconds and CPU seconds (it and its children)."""
    cpu, t0 = _children_cpu(), time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, timeout=7200)
    return done, time.perf_counter() - t0, _children_cpu() - cpu


def _study(folder: Path, name: str, *, instances: int, trials: int, workers: int, isolation: str) -> tuple[Path, float]:
    config = folder / f"{name}.yaml"
    text = STUDY.format(name=name, instances=instances, trials=trials, workers=workers, isolation=isolation)
    config.write_text(text)
    out = folder / name / "results.jsonl"
    done, _, cpu = _timed([*CLI, "eval", str(config), "--out", str(out), "--quiet"])
    assert done.returncode == 0, done.stderr
    return out, cpu


def _verdicts(rows: list[AttemptRow]) -> dict[tuple[Any, ...], tuple[Any, ...]]:
    return {
        (r.trial, r.memory_iteration, r.task): (
            r.outcome,
            r.true_success,
            r.believed_success,
            r.tool_calls,
            r.robot_actions,
            tuple(r.perturbations),
            tuple(sorted(r.errors.items())),
        )
        for r in rows
    }


def _verify(target: Path) -> tuple[dict[str, Any], float, float]:
    done, wall, cpu = _timed([*CLI, "submit", "verify", str(target)])
    assert done.returncode == 0, done.stdout + done.stderr
    record = json.loads(target.with_name(target.stem + ".replay.json").read_text())
    return record, wall, cpu


def _determinism(folder: Path) -> dict[str, Any]:
    runs = {
        "stdio_1_worker": dict(workers=1, isolation="process"),
        "stdio_2_workers": dict(workers=2, isolation="process"),
        "fleet_2_workers": dict(workers=2, isolation="fleet"),
    }
    verdicts, replays = {}, {}
    for name, how in runs.items():
        out, _ = _study(folder, name, instances=INSTANCES, trials=1, **how)  # type: ignore[arg-type]
        rows = read_rows(out)
        verdicts[name] = _verdicts(rows)
        record, _, _ = _verify(out)
        replays[name] = {s: sum(r["status"] == s for r in record["rows"]) for s in ("matches", "differs", "skipped")}
    first = verdicts["stdio_1_worker"]
    figures: dict[str, Any] = {
        "replay.determinism.attempts": len(first),
        "replay.determinism.perturbed_attempts": sum(1 for v in first.values() if v[5]),
        "replay.determinism.with_earlier_tasks": sum(1 for k in first if "-pre" in str(k[2])),
        "replay.determinism.successes": sum(1 for v in first.values() if v[1]),
    }
    for name in runs:  # each run's verdicts against stdio with 1 worker, and its replay
        figures[f"replay.determinism.{name}.same_verdicts"] = verdicts[name] == first
        figures[f"replay.determinism.{name}.replay_matches"] = replays[name]["matches"]
        figures[f"replay.determinism.{name}.replay_differs"] = replays[name]["differs"]
    return figures


def _scale(folder: Path) -> dict[str, Any]:
    out, eval_cpu = _study(folder, "scale", instances=SCALE, trials=1, workers=2, isolation="process")
    rows = read_rows(out)
    submission = folder / "scale.json"
    t0 = time.perf_counter()
    done = subprocess.run(
        [*CLI, "submit", "prepare", str(out), "--out", str(submission)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    prepare_s = time.perf_counter() - t0
    record, wall, cpu = _verify(submission if SCALE >= 440 else out)
    replayed = [r for r in record["rows"] if r["status"] in ("matches", "differs")]
    per_row = {r["row"]: r["seconds"] for r in replayed}
    ratios = [per_row[i + 1] / row.wall_s for i, row in enumerate(rows) if i + 1 in per_row and row.wall_s > 0]
    return {
        "replay.scale.attempts": len(rows),
        "replay.scale.replayed": len(replayed),
        "replay.scale.differs": sum(r["status"] == "differs" for r in record["rows"]),
        "replay.scale.submission_mb": round(submission.stat().st_size / 1e6, 1),
        "replay.scale.prepare_s": round(prepare_s, 1),
        "replay.scale.verify_wall_s": round(wall, 1),
        "replay.scale.verify_cpu_s": round(cpu, 1),
        "replay.scale.eval_cpu_s": round(eval_cpu, 1),
        "replay.per_attempt.replay_s_p50": round(statistics.median(per_row.values()), 3),
        "replay.per_attempt.attempt_wall_s_p50": round(statistics.median(r.wall_s for r in rows), 3),
        "replay.per_attempt.replay_over_attempt_wall_p50": round(statistics.median(ratios), 2),
        "replay.per_attempt.eval_cpu_s": round(eval_cpu / len(rows), 3),
        "replay.per_attempt.verify_cpu_s": round(cpu / max(1, len(replayed)), 3),
    }


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="bench-replay-") as tmp:
        folder = Path(tmp)
        figures = _determinism(folder)
        figures |= _scale(folder)
    return figures


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
