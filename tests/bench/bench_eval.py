"""Evaluation figures: assets/eval/scripted.yaml shrunk to 20 trials x 2 memory iterations x 2 tasks,
with 2 workers and with 1."""

from __future__ import annotations

import asyncio
import json
import tempfile
import time
from pathlib import Path

from robocog.agent.harness.study import run_eval
from robocog.shared.evaluation import load_config

CONFIG = Path(__file__).resolve().parents[2] / "assets" / "eval" / "scripted.yaml"


def _timed(workers: int) -> tuple[float, int]:
    config = load_config(CONFIG).model_copy(update={"trials": 20, "memory_iterations": 2, "tasks": ["T1", "T2"]})
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        rows = asyncio.run(run_eval(config, Path(tmp) / "results.jsonl", workers=workers))
        return time.perf_counter() - start, len(rows)


def run() -> dict[str, float]:
    two, n = _timed(2)
    one, _ = _timed(1)
    return {
        "eval.scripted_20x2x2_attempts": n,
        "eval.scripted_20x2x2_2_workers_s": round(two, 2),
        "eval.scripted_20x2x2_1_worker_s": round(one, 2),
        "eval.speedup_2_over_1": round(one / two, 2),
        "eval.target_2_workers_s": 60.0,
        "eval.target_speedup": 1.6,
    }


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
