"""The taxonomy measured on an instrument: `scripted/faulty` commits each error class at a set rate
in a small study through `robocog eval` (robocog-v1 dev, two instances per family, two trials), and
the taxonomy must find what it committed, per class, in precision and recall; the false-success
rate must recover the rate the instrument set within its 95% interval.

The floors (0.8) leave room for a rare interaction the instrument cannot rule out (a wrong-order
grab the server answers without its move_to hint reads as an affordance error), while a category
that breaks (never counted, or counted on the wrong error) falls far below them: each class has
about ten committed attempts here, so two misses at most pass. The last test breaks the taxonomy on
purpose and sees the measure fail. robocog-v1 has no perturbations: the ignored perturbation is
measured on T1 with the mug moved away mid-task.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from robocog.agent.analysis import instrument
from robocog.agent.harness.study import run_eval
from robocog.agent.policies import faulty
from robocog.shared.evaluation import AttemptRow, EvalConfig
from robocog.shared.trace import ToolResult, read_trace

RATE = 0.5
FLOOR = 0.8
TAXONOMY = ("hallucination", "affordance", "wrong_order", "missing_step", "additional_step")
PARAMS = {"rate": RATE}


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[AttemptRow], Path]:
    config = EvalConfig.model_validate(
        {
            **{"name": "instrument-test", "suite": "robocog-v1", "split": "dev", "instances": 14, "trials": 2},
            **{"memory_iterations": 1, "seed": 0},
            "models": [{"model": "scripted/faulty", "params": PARAMS}],
        }
    )
    out = tmp_path_factory.mktemp("instrument") / "r.jsonl"
    return asyncio.run(run_eval(config, out)), out.parent


def test_the_taxonomy_finds_what_the_instrument_committed(study: tuple[list[AttemptRow], Path]) -> None:
    rows, base = study
    m = instrument.measure(rows, base, faulty.rates(PARAMS))
    assert m.attempts >= 20, instrument.table(m)
    for name in (*TAXONOMY, "false_success"):
        c = m.score(name)
        assert c.true_pos >= 2, f"{name} was hardly committed:\n{instrument.table(m)}"
        assert c.precision is not None and c.precision >= FLOOR, instrument.table(m)
        assert c.recall is not None and c.recall >= FLOOR, instrument.table(m)
    assert m.score("ignored_perturbation").recall is None, "robocog-v1 has no perturbations: not measurable"
    assert m.set_rate == RATE and m.recovered, instrument.table(m)


def test_the_rates_come_from_the_rows_and_the_command_prints_the_verdict(
    study: tuple[list[AttemptRow], Path], capsys: pytest.CaptureFixture[str]
) -> None:
    rows, base = study
    assert instrument.measure(rows, base) == instrument.measure(rows, base, faulty.rates(PARAMS))
    assert instrument.main([str(base / "r.jsonl")]) == 0
    out = capsys.readouterr().out
    assert "hallucination" in out and f"set {RATE:.3f}: recovered" in out


def test_the_committed_errors_happen_on_the_server(study: tuple[list[AttemptRow], Path]) -> None:
    """The errors are real calls the server refused, with the codes the taxonomy reads."""
    rows, base = study
    codes: set[str] = set()
    for row in rows:
        assert row.trace is not None or row.outcome == "not_run"  # an instance not run has no trace
        if row.trace is None:
            continue
        path = base / row.trace
        if path.exists():
            codes |= {str(e.structured.get("error")) for e in _results(path) if e.structured}
    assert {"unknown_location", "unknown_position", "nothing_held", "already_holding", "not_at_location"} <= codes


def test_a_broken_taxonomy_fails_the_measure(
    study: tuple[list[AttemptRow], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Not a tautology: a taxonomy that mistakes one category for another loses precision and
    recall on both."""
    rows, base = study
    real = instrument.classify

    def swapped(*args: object, **kwargs: object) -> dict[str, int]:
        counts = real(*args, **kwargs)  # type: ignore[arg-type]
        counts["affordance"], counts["wrong_order"] = counts["wrong_order"], counts["affordance"]
        return counts

    monkeypatch.setattr(instrument, "classify", swapped)
    m = instrument.measure(rows, base, faulty.rates(PARAMS))
    for name in ("affordance", "wrong_order"):
        c = m.score(name)
        assert (c.precision or 0) < FLOOR or (c.recall or 0) < FLOOR, instrument.table(m)


def test_an_ignored_perturbation_is_found_where_the_mug_moved(tmp_path: Path) -> None:
    """T1 with the mug moved away mid-task: the planner notices (its grab fails, it looks again),
    the instrument ignoring it does not, and claims success; the stand-in detector tells them apart,
    and the false claims follow the rate."""
    params = {"rate": 0.0, "rate_ignored_perturbation": RATE}
    config = EvalConfig.model_validate(
        {
            **{"name": "instrument-moved", "tasks": ["T1"], "trials": 6, "memory_iterations": 1, "seed": 0},
            "perturbations": [{"kind": "move_object", "object": "mug", "at_call": 4}],
            "models": [{"model": "scripted/faulty", "params": params}],
        }
    )
    rows = asyncio.run(run_eval(config, tmp_path / "r.jsonl"))
    m = instrument.measure(rows, tmp_path, faulty.rates(params))
    c = m.score("ignored_perturbation")
    assert c.true_pos >= 2 and c.false_pos + c.false_neg == 0, instrument.table(m)
    assert m.recovered, instrument.table(m)


def _results(path: Path) -> list[ToolResult]:
    return [e for e in read_trace(path) if isinstance(e, ToolResult)]
