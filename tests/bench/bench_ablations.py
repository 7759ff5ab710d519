"""Capabilities proven by ablation (issue 44): the oracle and, per capability tag, the oracle with that
one capability taken away (`scripted/without-<tag>`, `robocog.agent.policies.ablations`), through
`robocog eval` (2 workers) on a sample of robocog-v2.1's dev split spread over the families
(`ROBOCOG_ABLATION_INSTANCES`, default 88: 8 per family, `robocog.shared.suite.select`), one trial.

Figures, per tag (`robocog.agent.analysis.validity`): the ablation's success on the sampled instances
tagged with its capability and on the others (n each), the oracle's on the same sets, and whether it
meets the aims (at most 20% on the tagged, at least 95% on the others). It draws the report's
capability radar of the nine models into docs/capability-ablations.png. `ROBOCOG_BENCH_KEEP=DIR`
keeps the results file and traces in DIR (`robocog report DIR/ablations/r.jsonl` draws the table).
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

from robocog.agent.analysis.capability_figure import draw_capability
from robocog.agent.analysis.scores import capability_scores
from robocog.agent.analysis.validity import ORACLE, capability_validity
from robocog.agent.harness.study import run_eval
from robocog.agent.policies import ablations
from robocog.shared.evaluation import AttemptRow, EvalConfig, instance_rows

SUITE = "robocog-v2.1"
INSTANCES = int(os.environ.get("ROBOCOG_ABLATION_INSTANCES", "88"))
KEEP = os.environ.get("ROBOCOG_BENCH_KEEP")
RADAR = Path(__file__).resolve().parents[2] / "docs" / "capability-ablations.png"


def draw_radar(rows: list[AttemptRow], path: Path = RADAR) -> None:
    """The report's capability radar of the study (the oracle and every ablation), saved at `path`."""
    with tempfile.TemporaryDirectory() as tmp:
        name = draw_capability(capability_scores(instance_rows(rows)), Path(tmp), group="capability")
        if name is not None:
            (Path(tmp) / name).replace(path)


def run(instances: int = INSTANCES) -> dict[str, Any]:
    config = EvalConfig.model_validate(
        {
            **{"name": "ablations", "suite": SUITE, "split": "dev", "instances": instances},
            **{"trials": 1, "memory_iterations": 1, "workers": 2, "seed": 0},
            "models": [{"model": ORACLE}, *({"model": ablations.model(t)} for t in ablations.TAGS)],
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        out = (Path(KEEP) / "ablations" if KEEP else Path(tmp)) / "r.jsonl"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.unlink(missing_ok=True)
        start = time.perf_counter()
        rows = asyncio.run(run_eval(config, out))
        wall = time.perf_counter() - start
    table = capability_validity(rows)
    draw_radar(rows)
    figures: dict[str, Any] = {
        "ablations.suite": f"{SUITE}/dev",
        "ablations.instances": len(config.tasks),
        "ablations.eval_2_workers_s": round(wall, 1),
    }
    for v in table:
        key = f"ablations.{v.tag}"
        for name, share in (("tagged", v.tagged), ("untagged", v.untagged)):
            figures[f"{key}.{name}"] = None if share.rate is None else round(share.rate, 3)
            figures[f"{key}.{name}_n"] = share.n
        for name, oracle in (("oracle_tagged", v.oracle_tagged), ("oracle_untagged", v.oracle_untagged)):
            figures[f"{key}.{name}"] = None if oracle is None or oracle.rate is None else round(oracle.rate, 3)
        figures[f"{key}.valid"] = v.fails_tagged and v.passes_untagged
        figures[f"{key}.untagged_failed"] = sorted(
            r.instance or r.task
            for r in rows
            if r.model == v.model and r.earlier is None and v.tag not in r.capabilities and not r.true_success
        )
        print(
            f"bench_ablations: without {v.tag}: tagged {v.tagged.successes}/{v.tagged.n}, "
            f"others {v.untagged.successes}/{v.untagged.n}",
            file=sys.stderr,
        )
    return figures


if __name__ == "__main__":
    print(json.dumps(run(), indent=1))
