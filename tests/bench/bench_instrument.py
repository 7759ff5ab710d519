"""The taxonomy on its instrument, at full size: `scripted/faulty` (each error class committed at
`RATE`, seeded) on every instance of a suite's split through `robocog eval` (2 workers), scored by
`robocog.agent.analysis.instrument`: precision and recall per class against the injected truth,
and the false-success rate's 95% interval against the rate the instrument set.

`SUITE` and `SPLIT` (environment variables `ROBOCOG_INSTRUMENT_SUITE`, `ROBOCOG_INSTRUMENT_SPLIT`)
pick the instances (robocog-v2.1's dev split, one trial, by default); a class the split cannot hold (no
perturbation in robocog-v1) records null, and a second, perturbed study (T1, the mug moved away
mid-task) measures the ignored perturbation on its own as well. `ROBOCOG_BENCH_KEEP=DIR` keeps the
results files and traces in DIR (to score them again: `python -m robocog.agent.analysis.instrument`).
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
from robocog.shared.suite import load_suite

SUITE = os.environ.get("ROBOCOG_INSTRUMENT_SUITE", "robocog-v2.1")
KEEP = os.environ.get("ROBOCOG_BENCH_KEEP")
SPLIT = os.environ.get("ROBOCOG_INSTRUMENT_SPLIT", "dev")
RATE = 0.3
TRIALS = 1


def _round(x: float | None) -> float | None:
    return None if x is None else round(x, 3)


#: The perturbed study: T1 with the mug moved away mid-task (the planner notices it when its grab
#: fails, and looks again), only `ignored_perturbation` committed.
MOVED_MUG = {"kind": "move_object", "object": "mug", "at_call": 4}
PERTURBED_TRIALS = 20


def measure(study: dict[str, Any], params: dict[str, Any]) -> tuple[instrument.Measure, float]:
    """Run a study of `scripted/faulty` with `params` and score it; and its wall time. A suite's one
    trial is one unit, which one worker runs: its families are split into two studies, run at once
    (the same seeds, so the same draws), and scored together."""
    base = {**study, **{"name": "instrument", "memory_iterations": 1, "seed": 0}}
    base["models"] = [{"model": "scripted/faulty", "params": params}]
    if "suite" in study:
        families = list(load_suite(study["suite"]).families)
        halves = [families[0::2], families[1::2]]  # the long families (long_horizon, search) apart
        configs = [EvalConfig.model_validate({**base, "families": h, "workers": 1}) for h in halves]
    else:
        configs = [EvalConfig.model_validate({**base, "workers": 2})]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(KEEP) if KEEP else Path(tmp)
        outs = [root / f"{c.tasks[0]}-{len(c.tasks)}" / "r.jsonl" for c in configs]
        for out in outs:
            out.parent.mkdir(parents=True, exist_ok=True)
            out.unlink(missing_ok=True)

        async def studies() -> list[list[Any]]:
            return list(await asyncio.gather(*(run_eval(c, o) for c, o in zip(configs, outs, strict=True))))

        start = time.perf_counter()
        results = asyncio.run(studies())
        wall = time.perf_counter() - start
        judged: list[instrument.Attempt] = []
        skipped = 0
        for rows, out in zip(results, outs, strict=True):
            attempts, not_run = instrument.attempts_of(rows, out.parent, faulty.rates(params))
            judged += attempts
            skipped += not_run
        return instrument.score(judged, skipped), wall


def perturbed(rate: float = 0.5, trials: int = PERTURBED_TRIALS) -> dict[str, Any]:
    """`ignored_perturbation` alone, on T1 with a moved mug: its precision, recall and the
    false-success check."""
    study = {"tasks": ["T1"], "trials": trials, "perturbations": [MOVED_MUG]}
    m, _ = measure(study, {"rate": 0.0, "rate_ignored_perturbation": rate})
    print(f"bench_instrument: T1 with a moved mug, {trials} trials\n{instrument.table(m)}", file=sys.stderr)
    c = m.score("ignored_perturbation")
    return {
        "instrument.perturbed.attempts": m.attempts,
        "instrument.perturbed.rate": rate,
        "instrument.perturbed.precision": _round(c.precision),
        "instrument.perturbed.recall": _round(c.recall),
        "instrument.perturbed.committed": c.true_pos + c.false_neg,
        "instrument.perturbed.false_success_rate": round(m.false_success_rate, 3),
        "instrument.perturbed.false_success_ci95": [round(m.interval[0], 3), round(m.interval[1], 3)],
        "instrument.perturbed.false_success_recovered": m.recovered,
    }


def run(suite: str = SUITE, split: str = SPLIT, rate: float = RATE, trials: int = TRIALS) -> dict[str, Any]:
    m, wall = measure({"suite": suite, "split": split, "trials": trials}, {"rate": rate})
    print(f"bench_instrument: {suite} {split}, rate {rate}, {trials} trials\n{instrument.table(m)}", file=sys.stderr)
    return figures_of(m, wall, suite, split, rate) | perturbed()


def figures_of(m: instrument.Measure, wall: float, suite: str, split: str, rate: float) -> dict[str, Any]:
    """The figures of the instrument's verdict on a suite's split."""
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
