"""The evaluation harness and the report, validated with the scripted instruments (offline)."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from robocog.agent.analysis.report import render
from robocog.agent.analysis.results_file import read_rows
from robocog.agent.analysis.stats import pass_hat_k, wilson
from robocog.agent.harness.progress import Progress
from robocog.agent.harness.scratch import PREFIX, SCRATCH_ENV
from robocog.agent.harness.study import run_eval
from robocog.agent.harness.units import unit_complete
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec, load_config
from robocog.shared.trace import ToolResult, read_trace
from tests.helpers import DATA, ROOT

pytestmark = pytest.mark.anyio
ASSETS = ROOT / "assets" / "eval"


def study(*models: ModelSpec, **overrides: object) -> EvalConfig:
    settings: dict[str, object] = {
        "name": "test",
        "models": list(models),
        "trials": 2,
        "memory_iterations": 2,
        "workers": 2,
    }
    settings.update(overrides)
    return EvalConfig.model_validate(settings)


# --- configs -------------------------------------------------------------------------------------


def test_shipped_configs_load() -> None:
    paper = load_config(ASSETS / "paper.yaml")
    assert [m.name for m in paper.models] == ["GPT-4.1", "Claude Sonnet 4", "Qwen3 Coder", "DeepSeek V3.1"]
    assert (paper.tasks, paper.memory_iterations) == (["T1", "T2"], 4)
    assert load_config(ASSETS / "scripted.yaml").models[0].model == "scripted/planner"


def test_a_bad_config_names_the_field(tmp_path: Path) -> None:
    bad = tmp_path / "study.yaml"
    bad.write_text("models:\n  - model: gpt-4.1\ntrials: zero\n")
    with pytest.raises(ConfigError, match=r"study\.yaml: trials: Input should be a valid integer"):
        load_config(bad)


# --- the protocol, validated with the instruments -------------------------------------------------


async def test_the_planner_always_succeeds_believes_truly_and_uses_the_optimal_calls(tmp_path: Path) -> None:
    rows = await run_eval(study(ModelSpec(model="scripted/planner")), tmp_path / "r.jsonl")
    assert len(rows) == 2 * 2 * 2
    assert all(r.true_success and r.believed_success and r.agreement and not r.stopped for r in rows)
    calls = {(r.memory_iteration, r.task): r.tool_calls for r in rows}
    # Iteration 0 learns that the TV cannot be grasped; iteration 1 remembers it and starts at the shelf.
    assert calls == {(0, "T1"): 18, (0, "T2"): 16, (1, "T1"): 16, (1, "T2"): 15}
    assert all((tmp_path / r.trace).exists() for r in rows if r.trace)


async def test_the_overconfident_model_shows_false_positives_at_its_rate_and_verified_memory_catches_them(
    tmp_path: Path,
) -> None:
    p, n = 0.5, 12
    config = study(
        ModelSpec(model="scripted/overconfident", params={"p": p}), tasks=["T1"], trials=n, memory_labels="verified"
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    first = [r for r in rows if r.memory_iteration == 0]
    false_positive = [r for r in first if r.believed_success and not r.true_success]
    assert all(r.believed_success for r in rows)
    assert abs(len(false_positive) / n - p) <= 3 * math.sqrt(p * (1 - p) / n)
    assert 0 < len(false_positive) < n
    # In the next iteration, search_memory shows those episodes as verified failures.
    for row in rows:
        if row.memory_iteration != 1:
            continue
        before = next(r for r in first if r.trial == row.trial)
        found = next(e for e in read_trace(tmp_path / str(row.trace)) if isinstance(e, ToolResult))
        assert found.name == "search_memory" and found.structured is not None
        memory = found.structured["results"][0]
        assert memory["status_source"] == "verified"
        assert memory["status"] == ("success" if before.true_success else "failure")


async def test_the_refuser_is_stopped_and_counted_as_a_failure(tmp_path: Path) -> None:
    rows = await run_eval(study(ModelSpec(model="scripted/refuser"), trials=1), tmp_path / "r.jsonl")
    assert [(r.task, r.stopped, r.invocations, r.true_success, r.believed_success) for r in rows] == [
        ("T1", True, 10, False, None)
    ] * 2


async def test_a_failing_model_call_fails_the_attempt_with_its_reason_not_the_run(tmp_path: Path) -> None:
    rows = await run_eval(
        study(ModelSpec(model="scripted/nonexistent"), trials=1, memory_iterations=1), tmp_path / "r.jsonl"
    )
    assert len(rows) == 1 and rows[0].error is not None and "unknown scripted model" in rows[0].error
    # A model-service failure is an error, never a refusal, and reads as one: no agreement, the error first.
    assert rows[0].outcome == "error" and not rows[0].stopped
    assert rows[0].agreement is None and rows[0].reason.startswith(rows[0].error)


async def test_existing_results_are_not_overwritten_without_resume(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    out.write_text((DATA / "results_small.jsonl").read_text())
    with pytest.raises(ConfigError, match="--resume"):
        await run_eval(study(ModelSpec(model="scripted/planner")), out)


def _stable(rows: list[AttemptRow]) -> list[tuple[object, ...]]:
    volatile = {"wall_s", "llm_latency_s", "trace"}  # traces are named after the results file
    return sorted(tuple(v for k, v in r.model_dump().items() if k not in volatile) for r in rows)


async def test_resume_after_a_kill_gives_exactly_the_rows_of_an_uninterrupted_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ram = tmp_path / "ram"  # stands for /dev/shm: the killed study's memory is left there, the next sweeps it up
    ram.mkdir()
    monkeypatch.setenv(SCRATCH_ENV, str(ram))
    config = study(ModelSpec(model="scripted/planner"), trials=3, workers=1)
    config_file = tmp_path / "study.yaml"
    config_file.write_text(json.dumps(config.model_dump(mode="json")))  # JSON is YAML
    killed = tmp_path / "killed.jsonl"
    proc = subprocess.Popen(
        [sys.executable, "-m", "robocog.agent.cli", "eval", str(config_file), "--out", str(killed), "--quiet"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if killed.exists() and len(killed.read_text().splitlines()) >= 3:  # midway through trial 0
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the run ended before it could be interrupted"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = read_rows(killed)
    assert 3 <= len(partial) < 12
    assert [p.name for p in ram.iterdir()] == [p.name for p in ram.glob(f"{PREFIX}{proc.pid}-*")] != []
    resumed = await run_eval(config, killed, resume=True)
    assert list(ram.iterdir()) == []
    uninterrupted = await run_eval(config, tmp_path / "whole.jsonl")
    assert len(resumed) == len(uninterrupted) == 12
    assert _stable(resumed) == _stable(uninterrupted)


# --- where a study's servers keep their memory ---------------------------------------------------


@pytest.mark.parametrize("isolation", ["process", "fleet"])
async def test_a_studys_servers_keep_its_memory_in_ram_across_iterations_and_leave_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, isolation: str
) -> None:
    ram = tmp_path / "ram"  # stands for /dev/shm (robocog.agent.harness.scratch)
    ram.mkdir()
    monkeypatch.setenv(SCRATCH_ENV, str(ram))
    seen: list[list[Path]] = []
    out = tmp_path / "r.jsonl"
    config = study(ModelSpec(model="scripted/planner"), trials=1, workers=1, tasks=["T1"], isolation=isolation)
    rows = await run_eval(config, out, on_progress=lambda _: seen.append(sorted(ram.glob("*/*/chroma.sqlite3"))))
    assert [(r.memory_iteration, r.true_success) for r in rows] == [(0, True), (1, True)]
    # While it ran, its server's (or fleet's) memory was in its own directory in RAM, none in its work directory.
    server = "worker-0" if isolation == "process" else "fleet-0"
    assert {tuple(p.relative_to(ram).parts[1:]) for files in seen for p in files} == {(server, "chroma.sqlite3")}
    assert all(p.parts[-3].startswith(f"{PREFIX}{os.getpid()}-") for files in seen for p in files)
    # Iteration 1 found what iteration 0 stored there.
    second = next(r for r in rows if r.memory_iteration == 1)
    search = next(
        e for e in read_trace(tmp_path / str(second.trace)) if isinstance(e, ToolResult) and e.name == "search_memory"
    )
    assert search.structured is not None and len(search.structured["results"]) == 1
    # Once it ended, nothing of it is left in RAM, nor its work directory.
    assert list(ram.iterdir()) == []
    assert not (tmp_path / "r.work").exists()


# --- task requirements ---------------------------------------------------------------------------


def _attempt(task: str, success: bool, error: str | None = None) -> AttemptRow:
    row = read_rows(DATA / "results_small.jsonl")[0]
    outcome = "error" if error else "ended"
    return row.model_copy(
        update={"task": task, "memory_iteration": 1, "true_success": success, "error": error, "outcome": outcome}
    )


def test_a_unit_is_complete_when_every_task_ran_or_lost_a_requirement() -> None:
    config = study(ModelSpec(model="scripted/planner"), tasks=["T1", "T2", "T3"])
    requires = {"T2": ["T1"]}  # T3 requires nothing: it runs even after T1 fails
    assert not unit_complete([_attempt("T1", False)], config, requires)
    assert unit_complete([_attempt("T1", False), _attempt("T3", True)], config, requires)
    assert not unit_complete([_attempt("T1", True), _attempt("T3", True)], config, requires)
    assert unit_complete([_attempt("T1", True), _attempt("T2", False), _attempt("T3", False)], config, requires)
    # An attempt errored (the server or the model service failed): the unit runs again on --resume.
    assert not unit_complete([_attempt("T1", False, "server failure: EOF")], config, requires)
    assert not unit_complete(
        [_attempt("T1", True), _attempt("T2", True, "ModelServiceError: 500"), _attempt("T3", True)], config, requires
    )


async def test_a_task_runs_only_after_the_tasks_it_requires_succeeded(tmp_path: Path) -> None:
    seen: list[Progress] = []
    config = study(ModelSpec(model="scripted/planner"), tasks=["T2", "T1"], trials=1, memory_iterations=1)
    rows = await run_eval(config, tmp_path / "r.jsonl", on_progress=seen.append)
    # T2 requires T1, which has not run yet when T2's turn comes: T2 is skipped, T1 runs.
    assert [(r.task, r.true_success) for r in rows] == [("T1", True)]
    assert (seen[-1].done, seen[-1].total, seen[-1].attempts) == (2, 2, 1)


# --- the report ----------------------------------------------------------------------------------


def test_wilson_and_pass_hat_k_match_hand_computation() -> None:
    lo, hi = wilson(3, 4)
    assert (round(lo, 4), round(hi, 4)) == (0.3006, 0.9544)
    assert wilson(0, 0) == (0.0, 1.0)
    assert pass_hat_k(1, 2, 1) == 0.5 and pass_hat_k(1, 2, 2) == 0.0 and pass_hat_k(3, 3, 2) == 1.0


def test_the_report_renders_from_a_committed_results_file(tmp_path: Path) -> None:
    rows = read_rows(DATA / "results_small.jsonl")
    report = render(rows, tmp_path / "report", title="small")
    out = report.parent
    for name in ("confusion.png", "memory_success.png", "memory_tool_calls.png", "results.csv", "summary.json"):
        assert (out / name).stat().st_size > 0, name
    text = report.read_text()
    assert "| alpha | 4 | 75.0% | 30.1% – 95.4% | 4 | 75.0% | 0 |" in text
    assert "| beta | 4 | 50.0% |" in text
    assert "![confusion matrices](confusion.png)" in text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["confusion"] == {
        "alpha": {"tp": 5, "fp": 2, "fn": 0, "tn": 0},
        "beta": {"tp": 2, "fp": 0, "fn": 1, "tn": 3},
    }
    alpha_t1 = next(r for r in summary["table"] if (r["model"], r["task"]) == ("alpha", "T1"))
    assert (alpha_t1["pass^1"], alpha_t1["pass^2"], alpha_t1["tool_calls"]) == (0.75, 0.5, 16)
    assert [p["rate"] for p in alpha_t1["by_memory_iteration"]] == [1.0, 0.5]
    beta_t2 = next(r for r in summary["table"] if (r["model"], r["task"]) == ("beta", "T2"))
    assert (beta_t2["executions"], beta_t2["successes"]) == (2, 1)
    with (out / "results.csv").open() as f:
        table = list(csv.reader(f))
    assert table[0] == [
        "Model",
        "Memory",
        "Task",
        "Trial",
        "Invokes",
        "Toolcalls",
        "Belief",
        "Truth",
        "Accuracy",
        "Stopped",
        "Success",
        "Feasible",
    ]
    assert table[8] == ["beta", "0", "T1", "0", "10", "0", "False", "False", "True", "True", "False", "True"]


def test_robocog_report_command(tmp_path: Path) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "robocog.agent.cli",
            "report",
            str(DATA / "results_small.jsonl"),
            "--out",
            str(tmp_path / "r"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "r" / "report.md").exists()
    missing = subprocess.run(
        [
            sys.executable,
            "-m",
            "robocog.agent.cli",
            "report",
            str(tmp_path / "nope.jsonl"),
            "--out",
            str(tmp_path / "x"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert missing.returncode == 2 and "no such results file" in missing.stderr


# --- the command line ------------------------------------------------------------------------------


def _eval_cli(config: EvalConfig, tmp_path: Path, *flags: str) -> subprocess.CompletedProcess[str]:
    config_file = tmp_path / "study.yaml"
    config_file.write_text(json.dumps(config.model_dump(mode="json")))  # JSON is YAML
    command = [sys.executable, "-m", "robocog.agent.cli", "eval", str(config_file), "--quiet", *flags]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


def test_errored_attempts_are_warned_about_and_fail_the_eval_unless_allowed(tmp_path: Path) -> None:
    config = study(ModelSpec(model="scripted/nonexistent"), trials=1, memory_iterations=2, workers=1)
    run = _eval_cli(config, tmp_path, "--out", str(tmp_path / "a.jsonl"))
    assert run.returncode == 1, run.stderr
    assert "warning: scripted/nonexistent trial 0 iteration 0 T1 errored" in run.stdout + run.stderr
    assert "1 attempts errored" in run.stderr and "--resume" in run.stderr
    assert "(1 errored)" in run.stdout
    allowed = _eval_cli(config, tmp_path, "--out", str(tmp_path / "b.jsonl"), "--allow-errors")
    assert allowed.returncode == 0, allowed.stderr


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--trials", "0"], "robocog: --trials: Input should be greater than or equal to 1"),
        (["--memory-iterations", "-2"], "robocog: --memory-iterations: Input should be greater than or equal to 1"),
        (["--workers", "0"], "robocog: --workers: Input should be greater than or equal to 1"),
    ],
)
def test_command_line_overrides_are_validated_like_the_config(tmp_path: Path, flags: list[str], message: str) -> None:
    run = _eval_cli(study(ModelSpec(model="scripted/planner")), tmp_path, "--out", str(tmp_path / "r.jsonl"), *flags)
    assert (run.returncode, run.stderr.strip()) == (2, message)
