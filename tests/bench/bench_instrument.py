"""The taxonomy on its instrument, at full size: `scripted/faulty` (each error class committed at
`RATE`, seeded) on every instance of a suite's split through `robocog eval` (2 workers), scored by
`robocog.agent.analysis.instrument`: precision and recall per class against the injected truth,
and the false-success rate's 95% interval against the rate the instrument set.

`SUITE` and `SPLIT` (environment variables `ROBOCOG_INSTRUMENT_SUITE`, `ROBOCOG_INSTRUMENT_SPLIT`)
pick the instances; a class the split cannot hold (no perturbation in robocog-v1) records null.
"""

from __future__ import annotations

import asyncio
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from robocog.agent.analysis import instrument
from robocog.agent.harness.study import run_eval
from robocog.agent.policies import faulty
from robocog.shared.evaluation import EvalConfig

SUITE = os.environ.get("ROBOCOG_INSTRUMENT_SUITE", "robocog-v1")
SPLIT = os.environ.get("ROBOCOG_INSTRUMENT_SPLIT", "dev")
RATE = 0.3
TRIALS = 2


def _round(x: float | None) -> float | None:
    return None if x is None else round(x, 3)


def run(suite: str = SUITE, split: str = SPLIT, rate: float = RATE, trials: int = TRIALS) -> dict[str, Any]:
    params = {"rate": rate}
    config = EvalConfig.model_validate(
        {
            **{"name": "instrument", "suite": suite, "split": split, "trials": trials},
            **{"memory_iterations": 1, "workers": 2, "seed": 0},
            "models": [{"model": "scripted/faulty", "params": params}],
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.jsonl"
        start = time.perf_counter()
        rows = asyncio.run(run_eval(config, out))
        wall = time.perf_counter() - start
        m = instrument.measure(rows, out.parent, faulty.rates(params))
    print(f"bench_instrument: {suite} {split}, rate {rate}, {trials} trials\n{instrument.table(m)}", file=sys.stderr)
    figures: dict[str, Any] = {
        "instrument.suite": f"{suite}/{split}",
        "instrument.rate": rate,
        "instrument.attempts": m.attempts,
        "instrument.not_run": m.skipped,
    }
    for c in m.classes:
        figures[f"instrument.precision.{c.name}"] = _round(c.precision)
        figures[f"instrument.recall.{c.name}"] = _round(c.recall)
        figures[f"instrument.committed.{c.name}"] = c.true_pos + c.false_neg
    figures["instrument.false_success_rate"] = round(m.false_success_rate, 3)
    figures["instrument.false_success_ci95"] = [round(m.interval[0], 3), round(m.interval[1], 3)]
    figures["instrument.false_success_set_rate"] = round(m.set_rate, 3)
    figures["instrument.false_success_recovered"] = m.recovered
    figures["instrument.eval_2_workers_s"] = round(wall, 1)
    return figures


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
