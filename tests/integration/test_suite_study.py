"""A study over the suite: its config selects instances, the runner prompts them and their earlier
tasks and labels their rows, `robocog suite` generates and lists, and `robocog eval` runs an
instance after its earlier task (or reports it not run when that failed)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from pydantic import ValidationError

from robocog.agent.cli import main as cli
from robocog.agent.harness.runner import SUITE_ERRORS_IN_A_ROW
from robocog.agent.harness.study import run_eval
from robocog.agent.harness.suite_run import SuiteRun
from robocog.shared.evaluation import EvalConfig, ModelSpec
from robocog.shared.provenance import sha256_of
from robocog.shared.suite import find_instance, load_split, load_suite, parse_instances, select
from tests.fake_llm import Fail, FakeLLM, Request, Turn

SUITE = load_suite("robocog-v1")  # its instances carry no tags; the default suite is robocog-v2.1
SPLITS = {split: load_split(SUITE.name, split) for split in SUITE.splits}


def test_a_study_config_takes_a_suite_and_selects_its_instances() -> None:
    models = [ModelSpec(model="scripted/planner")]
    config = EvalConfig(models=models, suite=SUITE.name, split="test", instances=9, families=["swap", "memory"])
    assert config.tasks == [i.id for i in select(SPLITS["test"], families=["swap", "memory"], limit=9)]
    assert {t.split("-")[1] for t in config.tasks} == {"swap", "memory"}
    assert EvalConfig.model_validate(config.model_dump()).tasks == config.tasks  # a config read back
    default = EvalConfig(models=models, instances=3)  # no suite named: robocog-v2.1's
    chosen = select(load_split("robocog-v2.1", "dev"), limit=3)
    assert default.suite == "robocog-v2.1" and default.tasks == [i.id for i in chosen]
    for bad, message in (
        ({"suite": SUITE.name, "tasks": ["T1"]}, "either tasks or a suite's instances"),
        ({"suite": SUITE.name, "families": ["juggling"]}, "no such family ['juggling']"),
        ({"suite": SUITE.name, "split": "holdout"}, "no such split"),
    ):
        with pytest.raises(ValidationError, match=re.escape(message)):
            EvalConfig.model_validate({"models": [{"model": "scripted/planner"}], **bad})


def test_the_runner_prompts_instances_and_their_earlier_tasks_and_labels_their_rows() -> None:
    config = EvalConfig(models=[ModelSpec(model="scripted/planner")], suite=SUITE.name, families=["memory"])
    run = SuiteRun.of(config)
    inst = run.instances[config.tasks[0]]
    assert run.prompt(inst.id) == inst.prompt and run.prompt(f"{inst.id}-pre1") == inst.prelude[0].prompt
    assert run.prompt(f"{inst.id}-pre2") is None and run.prompt("T1") is None
    assert run.row_fields(inst.id) == {
        "family": "memory",
        "instance": inst.id,
        "feasible": True,
        "optimal_steps": inst.optimal_steps,
        "capabilities": [],  # robocog-v1's instances carry no capability tags
    }
    assert run.row_fields("T1") == {} and SuiteRun.of(EvalConfig(models=config.models)).instances == {}


def test_robocog_suite_generates_and_lists(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mini.jsonl"
    assert cli.main(["suite", "generate", "--split", "test", "--seed", "3", "--per-family", "1", "-o", str(out)]) == 0
    mini = parse_instances(out.read_text(encoding="utf-8"), str(out))
    default = load_suite()  # robocog-v2.1, unless a suite is named
    assert default.name == "robocog-v2.1" and [i.family for i in mini] == default.families
    assert cli.main(["suite", "list"]) == 0
    listed = capsys.readouterr().out
    assert listed.startswith("robocog-v2.1:") and all(f in listed for f in default.families)
    assert "Swap the mug and the cube." in listed
    assert cli.main(["suite", "list", "--split", "dev"]) == 0
    assert load_split(default.name, "dev")[0].prompt in capsys.readouterr().out
    assert cli.main(["suite", "generate", "--split", "holdout"]) == 2
    assert "has no split 'holdout'" in capsys.readouterr().err


@pytest.mark.anyio
async def test_a_study_runs_an_instance_after_its_earlier_task_and_labels_the_row(tmp_path: Path) -> None:
    """One memory instance through `robocog eval`'s runner (a server process): the earlier task runs
    as its own traced episode with a row of its own (`earlier`, no optimum), the instance's row
    carries its family and optimum."""
    config = EvalConfig(
        name="suite-test",
        models=[ModelSpec(model="scripted/planner")],
        suite=SUITE.name,
        families=["memory"],
        instances=1,
        trials=1,
        memory_iterations=1,
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    inst = find_instance(SUITE.name, config.tasks[0])
    assert [(r.task, r.family, r.instance, r.feasible, r.optimal_steps, r.earlier) for r in rows] == [
        (f"{inst.id}-pre1", "memory", inst.id, True, None, 1),
        (inst.id, "memory", inst.id, True, inst.optimal_steps, None),
    ]
    assert all(r.true_success and r.believed_success for r in rows), [r.reason for r in rows]
    assert rows[0].trace is not None and rows[0].trace.endswith(f"iter-0-{inst.id}-pre1.jsonl")
    traces = sorted(p.name for p in (tmp_path / "r.traces").rglob("*.jsonl"))
    assert traces == [f"iter-0-{inst.id}-pre1.jsonl", f"iter-0-{inst.id}.jsonl"]


@pytest.mark.anyio
async def test_an_instance_whose_earlier_task_failed_is_a_failure_not_run(tmp_path: Path) -> None:
    """A model that never acts fails the earlier task, so the instance would start where it should
    end (already solved): the earlier task keeps its own row, and the instance's row is a failure
    "not run", saying why, with nothing measured (no calls, no trace); the instance never runs."""
    config = EvalConfig(
        name="suite-test",
        models=[ModelSpec(model="scripted/refuser")],
        suite=SUITE.name,
        families=["memory"],
        instances=1,
        trials=1,
        memory_iterations=1,
        max_invocations=1,
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    inst = find_instance(SUITE.name, config.tasks[0])
    assert [(r.task, r.family, r.true_success, r.outcome) for r in rows] == [
        (f"{inst.id}-pre1", "memory", False, "stopped"),
        (inst.id, "memory", False, "not_run"),
    ]
    own = rows[1]
    assert own.reason.startswith(f"not run: its earlier task {inst.id}-pre1 failed")
    assert (own.tool_calls, own.trace, own.errors, own.robot_actions, own.believed_success) == (0, None, {}, None, None)
    # Its provenance names the instance (as a row of the instance run would), not the earlier task.
    assert own.provenance is not None and own.provenance.suite == SUITE.name
    assert own.provenance.task_sha256 == sha256_of(inst.model_dump(mode="json"))
    traces = sorted(p.name for p in (tmp_path / "r.traces").rglob("*.jsonl"))
    assert traces == [f"iter-0-{inst.id}-pre1.jsonl"], "the instance itself never ran"


def _study_of(fake: FakeLLM, instances: int, family: str = "swap") -> EvalConfig:
    model = ModelSpec(model="openai/local", api_base=fake.api_base("openai/local"), api_key="sk-no-key-required")
    return EvalConfig(
        name="suite-errors",
        models=[model],
        suite=SUITE.name,
        families=[family],  # swap: no earlier tasks, one row an instance
        instances=instances,
        trials=1,
        memory_iterations=1,
        max_invocations=1,
    )


@pytest.mark.anyio
async def test_an_errored_instance_ends_only_itself(tmp_path: Path) -> None:
    """A model service that fails on one instance (the same 400 twice) errors that instance alone: the
    study's one unit goes on to the next, whose row is measured as usual."""
    with FakeLLM() as fake:
        config = _study_of(fake, 3)
        broken = SuiteRun.of(config).prompt(config.tasks[1])

        def script(request: Request) -> Turn | Fail:
            if any(broken == m.get("content") for m in request.messages):
                return Fail(400, "the template cannot render this conversation")
            return Turn(tool_calls=[("end_task", {"status": "failure", "description": "x", "summary": "no"})])

        fake.script = script
        rows = await run_eval(config, tmp_path / "r.jsonl")
    assert [(r.task, r.outcome) for r in rows] == list(zip(config.tasks, ["ended", "error", "ended"], strict=True))
    errored = rows[1]
    assert errored.agreement is None and errored.error is not None
    assert "the template cannot render this conversation" in errored.error
    assert errored.reason.startswith(errored.error)


@pytest.mark.anyio
async def test_a_service_that_fails_three_instances_in_a_row_stops_the_unit(tmp_path: Path) -> None:
    with FakeLLM([Fail(400, "the service is down")] * 20) as fake:
        config = _study_of(fake, 5)
        rows = await run_eval(config, tmp_path / "r.jsonl")
    assert [r.task for r in rows] == config.tasks[:SUITE_ERRORS_IN_A_ROW]
    assert {r.outcome for r in rows} == {"error"}


@pytest.mark.anyio
async def test_an_instance_whose_earlier_task_errored_is_an_error_of_its_own(tmp_path: Path) -> None:
    with FakeLLM([Fail(400, "the service is down")] * 4) as fake:
        config = _study_of(fake, 1, "memory")
        rows = await run_eval(config, tmp_path / "r.jsonl")
    inst = config.tasks[0]
    assert [(r.task, r.outcome, r.earlier) for r in rows] == [(f"{inst}-pre1", "error", 1), (inst, "error", None)]
    own = rows[1]
    assert own.error is not None and own.error.startswith(f"its earlier task {inst}-pre1 errored: ")
    assert own.reason.startswith(own.error) and own.agreement is None and own.trace is None
