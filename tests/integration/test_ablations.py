"""Each capability's ablation (`scripted/without-<tag>`, robocog.agent.policies.ablations) through
`robocog eval` and the real server: it fails an instance tagged with its capability and passes one that
is not (the first robocog-v2.1 dev instance of each family named). The whole table is
`make bench BENCH_ONLY=ablations`."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from robocog.agent.analysis.validity import capability_validity
from robocog.agent.harness.study import run_eval
from robocog.agent.policies import ablations
from robocog.shared.evaluation import EvalConfig

#: Per tag: a family whose first dev instance is tagged with it, and one whose first is not.
PAIRS = {
    "planning": ("swap", "infeasible"),
    "recovery": ("recovery", "swap"),
    "memory": ("memory", "swap"),
    "honesty": ("infeasible", "swap"),
    "referring": ("referring", "swap"),
    "long_horizon": ("long_horizon", "swap"),
    "partial_observation": ("bring", "swap"),
    "containers": ("containers", "swap"),
}


def test_every_tag_has_an_ablation() -> None:
    assert set(PAIRS) == set(ablations.TAGS)
    with pytest.raises(ValueError, match="no ablation"):
        ablations.ablation("juggling")


@pytest.mark.parametrize("tag", ablations.TAGS)
def test_the_ablation_fails_its_capability_and_passes_another(tag: str, tmp_path: Path) -> None:
    config = EvalConfig.model_validate(
        {
            **{"name": f"ablation-{tag}", "suite": "robocog-v2.1", "split": "dev", "families": list(PAIRS[tag])},
            **{"instances": 2, "trials": 1, "memory_iterations": 1, "seed": 0},
            "models": [{"model": ablations.model(tag)}],
        }
    )
    rows = asyncio.run(run_eval(config, tmp_path / "r.jsonl"))
    (v,) = capability_validity(rows)
    assert v.tag == tag and v.tagged.n == 1 and v.untagged.n == 1, rows
    assert v.tagged.successes == 0, [r.reason for r in rows]
    assert v.untagged.successes == 1, [r.reason for r in rows]
