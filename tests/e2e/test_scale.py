"""Scale: the scripted models' latency model, a shared Chroma server behind two robots, and studies
run on a real (loopback) Ray cluster giving the rows of a local run."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcp import Client

from robocog.agent.analysis.results_file import read_rows
from robocog.agent.harness.study import run_eval
from robocog.shared.errors import ModelServiceError, ServerConnectionError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec
from robocog.shared.trace import ModelTurn, read_trace
from tests.chroma_server import chroma_server
from tests.helpers import RAY_ENV, free_port, ray_cluster, stdio_params

pytestmark = pytest.mark.anyio

#: What differs between two runs of the same study: how long things took, and where traces went.
TIMING = {"llm_latency_s", "wall_s", "trace"}


#: The scripted models' latency parameters: a row's provenance records them with the others.
LATENCY_PARAMS = {"latency_s", "jitter_s"}


def outcome(rows: list[AttemptRow]) -> list[dict[str, Any]]:
    """The rows without their timing fields (nor the latency among their provenance's parameters), in
    a stable order."""
    kept = [r.model_dump(exclude=TIMING) for r in rows]
    for row in kept:
        if row.get("provenance"):
            row["provenance"]["params"] = {
                k: v for k, v in row["provenance"]["params"].items() if k not in LATENCY_PARAMS
            }
    return sorted(kept, key=lambda r: (r["model"], r["trial"], r["memory_iteration"], r["task"]))


def study(*models: ModelSpec, **overrides: object) -> EvalConfig:
    settings: dict[str, object] = {"name": "scale", "models": list(models), "trials": 2, "memory_iterations": 2}
    settings.update(overrides)
    return EvalConfig.model_validate(settings)


# --- the latency model ---------------------------------------------------------------------------


def test_jitter_is_seeded_bounded_and_independent_of_the_decisions() -> None:
    from robocog.agent.policies.offline import turn_delay

    draws = [turn_delay(1.0, 0.2, seed=7, turn=t) for t in range(1, 50)]
    assert draws == [turn_delay(1.0, 0.2, seed=7, turn=t) for t in range(1, 50)]  # reproducible
    assert all(0.8 <= d <= 1.2 for d in draws)
    assert len(set(draws)) > 40  # a draw per turn, not one per run
    assert draws != [turn_delay(1.0, 0.2, seed=8, turn=t) for t in range(1, 50)]
    assert turn_delay(0.5, 0.0, seed=None, turn=3) == 0.5
    assert turn_delay(0.0, 0.3, seed=1, turn=1) >= 0.0  # never negative


async def test_a_bad_latency_is_a_model_error_not_retried() -> None:
    from robocog.agent.client.model import complete
    from robocog.agent.client.settings import AgentSettings

    settings = AgentSettings(model="scripted/planner", params={"latency_s": -1})
    with pytest.raises(ModelServiceError, match="latency_s must be a non-negative number of seconds"):
        await complete(settings, [{"role": "user", "content": "hello"}], [])


def test_the_sync_completion_waits_too() -> None:
    import litellm

    from robocog.agent.policies.providers import register

    register()
    response = litellm.completion(
        model="scripted/refuser", messages=[{"role": "user", "content": "hi"}], latency_s=0.2, seed=1
    )
    # LiteLLM measures the call itself: the wait happened inside it.
    assert response._response_ms >= 200


async def test_latency_changes_the_timing_of_a_study_and_nothing_else(tmp_path: Path) -> None:
    latency = 0.2
    models = [("scripted/planner", {}), ("scripted/overconfident", {"p": 0.5})]
    plain = study(*(ModelSpec(model=m, params=p) for m, p in models), tasks=["T1"], trials=1, workers=2)
    # The planner waits exactly `latency` per turn; the overconfident model with a seeded jitter.
    jitter = {"scripted/planner": 0.0, "scripted/overconfident": 0.05}
    slow = study(
        *(ModelSpec(model=m, params={**p, "latency_s": latency, "jitter_s": jitter[m]}) for m, p in models),
        tasks=["T1"],
        trials=1,
        workers=2,
    )
    fast_rows = await run_eval(plain, tmp_path / "plain" / "r.jsonl")
    slow_rows = await run_eval(slow, tmp_path / "slow" / "r.jsonl")
    assert outcome(slow_rows) == outcome(fast_rows)
    for row in slow_rows:
        assert row.trace is not None
        turns = [e for e in read_trace(tmp_path / "slow" / row.trace) if isinstance(e, ModelTurn)]
        assert turns
        least = latency - jitter[row.model]
        assert all(t.latency_s >= least for t in turns)
        assert row.llm_latency_s >= len(turns) * least


# --- one Chroma server behind two robots ---------------------------------------------------------


@pytest.fixture
def chroma_url(tmp_path: Path) -> Iterator[str]:
    """A `chroma run` server (the CLI shipped with chromadb) on a free loopback port."""
    with chroma_server(tmp_path / "chroma") as url:
        yield url


async def test_one_robots_report_is_found_by_another_robot_through_a_shared_chroma_server(chroma_url: str) -> None:
    report = "The TV cannot be grasped: push it off the shelf edge first, then it slides into reach."
    async with (
        Client(stdio_params("--memory-url", chroma_url, "--memory-namespace", "fleet")) as first,
        Client(stdio_params("--memory-url", chroma_url, "--memory-namespace", "fleet")) as second,
    ):
        before = await second.call_tool("search_memory", {"query": "move the TV onto the table"})
        assert before.structured_content is not None and before.structured_content["results"] == []
        ended = await first.call_tool(
            "end_task", {"status": "failure", "description": "Move the TV onto the table.", "summary": report}
        )
        assert not ended.is_error and ended.structured_content is not None, ended.content
        assert ended.structured_content["status"] == "success"
        found = await second.call_tool("search_memory", {"query": "put the television on the table"})
        assert found.structured_content is not None, found.content
        results = found.structured_content["results"]
        assert [r["summary"] for r in results] == [report]
        assert results[0]["task_description"] == "Move the TV onto the table."
        assert results[0]["status"] == "failure"


# --- a study on a real Ray cluster (loopback) ----------------------------------------------------

BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def ray_address() -> Iterator[str]:
    with ray_cluster() as address:
        yield address


def robocog_eval(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [str(BIN / "robocog"), "eval", *args, "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**RAY_ENV, "LITELLM_LOCAL_MODEL_COST_MAP": "True"},
    )


def finished(proc: subprocess.Popen[str]) -> str:
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 0, f"exit {proc.returncode}\n{out}\n{err}"
    return out


def test_a_study_on_a_ray_cluster_gives_the_rows_of_a_local_run_and_resumes_the_same(
    ray_address: str, tmp_path: Path
) -> None:
    config = tmp_path / "study.yaml"
    config.write_text(
        yaml.safe_dump(
            {
                "name": "ray",
                "models": [{"model": "scripted/planner"}, {"model": "scripted/overconfident", "params": {"p": 0.5}}],
                "tasks": ["T1", "T2"],
                "trials": 2,
                "memory_iterations": 2,
                "workers": 2,
            }
        )
    )
    local_out, ray_out = tmp_path / "local" / "r.jsonl", tmp_path / "ray" / "r.jsonl"
    # The commands of the README: the same study run here and on the cluster (at once, to save time).
    local = robocog_eval(str(config), "--out", str(local_out))
    on_ray = robocog_eval(str(config), "--out", str(ray_out), "--ray", ray_address)
    finished(local)
    local_rows = read_rows(local_out)

    # --resume on the cluster: the driver keeps the complete units, drops a cut-off one, reruns it
    # (started as soon as there are rows to resume from; Ray schedules its actor when a CPU is free).
    resumed = tmp_path / "resumed" / "r.jsonl"
    resumed.parent.mkdir()
    cut = ("scripted/overconfident", 1)
    kept = [r for r in local_rows if r.unit != cut]
    cut_off = [r for r in local_rows if r.unit == cut][:1]
    resumed.write_text("".join(r.model_dump_json() + "\n" for r in [*kept, *cut_off]))
    resume = robocog_eval(str(config), "--out", str(resumed), "--ray", ray_address, "--resume")

    assert f"attempts in {ray_out}" in finished(on_ray)
    ray_rows = read_rows(ray_out)
    assert outcome(ray_rows) == outcome(local_rows)
    assert {r.model for r in ray_rows} == {"scripted/planner", "scripted/overconfident"}
    # Every attempt's trace came back to the driver, where a local run puts it.
    assert all(r.trace and (ray_out.parent / r.trace).exists() for r in ray_rows)
    assert sorted(str(r.trace) for r in ray_rows) == sorted(str(r.trace) for r in local_rows)
    first_trace = (ray_out.parent / str(ray_rows[0].trace)).read_text().splitlines()
    assert first_trace and all(json.loads(line) for line in first_trace)

    finished(resume)
    after = read_rows(resumed)
    assert outcome(after) == outcome(local_rows)
    assert [r.model_dump() for r in after[: len(kept)]] == [r.model_dump() for r in kept]  # kept as they were
    assert all(r.trace and (resumed.parent / r.trace).exists() for r in after if r.unit == cut)


def test_without_ray_the_flag_says_how_to_get_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robocog.agent.cli.main import main

    monkeypatch.setitem(sys.modules, "ray", None)  # as if the extra were not installed
    config = tmp_path / "study.yaml"
    config.write_text("models:\n  - model: scripted/planner\n")
    assert main(["eval", str(config), "--out", str(tmp_path / "r.jsonl"), "--ray"]) == 2
    err = capsys.readouterr().err
    assert err == "robocog: --ray needs Ray: pip install 'robocog[ray]'\n"
    assert not (tmp_path / "r.jsonl").exists()


def test_an_address_where_no_cluster_answers_fails_at_once_in_one_line() -> None:
    from robocog.agent.harness.ray_backend import check_reachable

    port = free_port()
    with pytest.raises(ServerConnectionError, match=rf"--ray: no Ray cluster answers at 127\.0\.0\.1:{port}"):
        check_reachable(f"127.0.0.1:{port}")


async def test_a_traces_pictures_travel_from_the_actor_to_the_driver(tmp_path: Path) -> None:
    """An actor sends a trace's pictures (look's) with its row; the driver writes them beside the
    trace, where a local run keeps them, and the actor's node-local copies are gone."""
    import asyncio

    from robocog.agent.client.trace_sinks import Trace
    from robocog.agent.harness.ray_backend import RemoteRunner, store_row
    from robocog.agent.harness.runner import Runner

    config = study(ModelSpec(model="scripted/planner"), trials=1, memory_iterations=1)
    actor = RemoteRunner(config, tmp_path / "actor" / "r.jsonl", None)
    trace_path = actor.traces_dir / "m" / "trial-0" / "iter-0-T1.jsonl"
    trace = Trace(trace_path)
    reference = trace.save_image(b"\x89PNG fake", tool="look")
    trace.close()
    row = AttemptRow.model_validate(
        {
            **{"model": "m", "trial": 0, "memory_iteration": 0, "task": "T1", "invocations": 1, "tool_calls": 1},
            **{"outcome": "ended", "believed_success": True, "true_success": True, "agreement": True},
            **{"stopped": False, "tokens_in": 0, "tokens_out": 0, "cost": None, "llm_latency_s": 0.0},
            **{"wall_s": 0.0, "seed": 0, "memory_labels": "believed", "version": "x"},
            "trace": str(trace_path.relative_to(actor.out.parent)),
        }
    )
    actor.forward.events = asyncio.Queue()
    await actor.write(row)
    kind, row_json, text, images = actor.forward.events.get_nowait()
    assert kind == "row" and text is not None and list(images.values()) == [b"\x89PNG fake"]
    assert not trace_path.exists() and not trace_path.with_name("iter-0-T1.images").exists()

    driver = Runner(config, tmp_path / "driver" / "r.jsonl")
    driver.out.parent.mkdir()
    await store_row(driver, AttemptRow.model_validate_json(row_json), text, images)
    written = (driver.out.parent / str(row.trace)).parent / reference  # the reference is relative to the trace
    assert written.read_bytes() == b"\x89PNG fake"
    assert read_rows(driver.out) == [row]
