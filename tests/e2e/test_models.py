"""Real model routes, over real HTTP: the agent loop against `tests.fake_llm` and a real robot server.

The fake model service speaks the OpenAI, Anthropic and Ollama APIs on loopback; the planner's
decisions are replayed through it (`planner_script`), so a full T1 runs through each LiteLLM route
and the robot's ground truth judges it; the tokens and cost come from the provider's usage; the
paper's study runs against the fake servers. The failures are in test_model_failures.py, the shared
setup in tests/e2e/model_routes.py and model_route_fixtures.py.
"""

from __future__ import annotations

from pathlib import Path

import litellm
import pytest

from robocog.agent.client.connection import Robot
from robocog.agent.client.model import PLACEHOLDER_KEY, check_credentials
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.trace import ModelTurn, ToolResult
from tests.e2e.model_route_fixtures import anyio_backend_fixture, fake_fixture, fresh_fixture, robot_fixture  # noqa: F401
from tests.e2e.model_routes import END, episode, sampled
from tests.fake_llm import FakeLLM, Turn, planner_script
from tests.helpers import ROOT

pytestmark = pytest.mark.anyio


# --- a full T1 through each route ----------------------------------------------------------------


async def test_a_keyless_local_openai_server_gets_the_placeholder_key_and_t1_succeeds(
    robot: Robot, fake: FakeLLM
) -> None:
    model = "openai/fake-model"
    fake.script = planner_script()
    check_credentials(model, fake.api_base(model))  # no key anywhere: not a credential error
    result, truth = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model), seed=7))
    assert (result.outcome, result.believed_success, truth, result.tool_calls) == ("ended", True, True, 18)
    requests = fake.model_requests
    assert len(requests) == 18 and {r.path for r in requests} == {"/v1/chat/completions"}
    assert {r.headers["authorization"] for r in requests} == {f"Bearer {PLACEHOLDER_KEY}"}
    assert {sampled(r)["seed"] for r in requests} == {7}


async def test_anthropic_with_a_seed_ends_t1_and_says_once_that_the_seed_is_not_sent(
    robot: Robot, fake: FakeLLM, capfd: pytest.CaptureFixture[str]
) -> None:
    model = "anthropic/claude-fake"
    fake.script = planner_script()
    settings = AgentSettings(model=model, api_base=fake.api_base(model), seed=7, temperature=0.6)
    result, truth = await episode(robot, settings)
    assert (result.outcome, result.believed_success, truth, result.error) == ("ended", True, True, None)
    requests = fake.model_requests
    assert {r.path for r in requests} == {"/v1/messages"} and len(requests) == 18
    assert not any("seed" in r.body for r in requests)
    assert {r.body["temperature"] for r in requests} == {0.6}  # what the provider takes is still sent
    assert {r.headers["x-api-key"] for r in requests} == {PLACEHOLDER_KEY}
    err = capfd.readouterr().err
    notice = f"robocog: {model} does not take 'seed'; it is not sent"
    assert err.count(notice) == 1, err
    assert "Give Feedback" not in err


async def test_ollama_chat_drives_t1_without_any_key(robot: Robot, fake: FakeLLM) -> None:
    model = "ollama_chat/fake-model"
    fake.script = planner_script()
    result, truth = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model), seed=7))
    assert (result.outcome, result.believed_success, truth, result.tool_calls) == ("ended", True, True, 18)
    requests = fake.model_requests
    assert {r.path for r in requests} == {"/api/chat"}
    assert not any("authorization" in r.headers for r in requests)
    assert {sampled(r)["seed"] for r in requests} == {7}
    assert result.cost is None  # LiteLLM prices an unknown Ollama model at 0.0: unknown, not free


async def test_hosted_vllm_drives_t1_without_the_openai_sdk(robot: Robot, fake: FakeLLM) -> None:
    # The same OpenAI API through LiteLLM's own HTTP handler (lighter than the SDK's; see `make bench`).
    model = "hosted_vllm/fake-model"
    fake.script = planner_script()
    result, truth = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model), temperature=0.6))
    assert (result.outcome, result.believed_success, truth) == ("ended", True, True)
    assert {r.path for r in fake.model_requests} == {"/v1/chat/completions"}
    assert {sampled(r)["temperature"] for r in fake.model_requests} == {0.6}


async def test_several_calls_a_malformed_one_and_a_text_turn_through_ollama(robot: Robot, fake: FakeLLM) -> None:
    # Ollama's route re-parses every tool call of the history: a malformed one must not break later calls.
    model = "ollama_chat/fake-model"
    fake.reply(
        Turn(tool_calls=[("look_around", {}), ("grab", '{"object": "cube"')]),
        Turn(text="I think I am done."),
        Turn(tool_calls=[END]),
    )
    trace = Trace()
    result, _ = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model)), trace)
    assert (result.outcome, result.invocations, result.tool_calls) == ("ended", 2, 3)
    results = [e for e in trace.events if isinstance(e, ToolResult)]
    assert [(e.name, e.is_error) for e in results] == [("look_around", False), ("grab", True), ("end_task", False)]
    assert "not a valid JSON object" in results[1].content
    assert len(fake.model_requests) == 3


# --- usage and cost ------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "priced"), [("openai/fake-model", None), ("openai/gpt-4o", "gpt-4o")])
async def test_tokens_come_from_the_providers_usage_and_cost_only_from_the_cost_map(
    robot: Robot, fake: FakeLLM, model: str, priced: str | None
) -> None:
    fake.reply(
        Turn(tool_calls=[("look_around", {})], usage=(1000, 20)),
        Turn(tool_calls=[("view_scratchpad", {})], usage=(1500, 30)),
        Turn(tool_calls=[END], usage=(2000, 40)),
    )
    trace = Trace()
    result, _ = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model)), trace)
    assert (result.outcome, result.tokens_in, result.tokens_out) == ("ended", 4500, 90)
    turns = [e for e in trace.events if isinstance(e, ModelTurn)]
    assert [(t.tokens_in, t.tokens_out) for t in turns] == [(1000, 20), (1500, 30), (2000, 40)]
    if priced is None:
        assert result.cost is None and all(t.cost is None for t in turns)
    else:
        rates = litellm.model_cost[priced]
        expected = 4500 * rates["input_cost_per_token"] + 90 * rates["output_cost_per_token"]
        assert result.cost == pytest.approx(expected)


# --- the paper's study, against the fake servers -------------------------------------------------


async def test_paper_yaml_runs_all_four_models_without_an_errored_attempt(fake: FakeLLM, tmp_path: Path) -> None:
    from robocog.agent.harness.study import run_eval
    from robocog.shared.evaluation import load_config

    config = load_config(ROOT / "assets" / "eval" / "paper.yaml")
    assert config.protocol == "paper" and len(config.models) == 4
    sampling = {m.name: m.params.get("temperature") for m in config.models}
    assert sampling == {"GPT-4.1": None, "Claude Sonnet 4": None, "Qwen3 Coder": 0.6, "DeepSeek V3.1": 0.6}
    models = [m.model_copy(update={"api_base": fake.api_base(m.model), "api_key": "sk-paper"}) for m in config.models]
    config = config.model_copy(update={"models": models, "trials": 1, "memory_iterations": 1, "workers": 1})
    fake.script = planner_script()
    rows = await run_eval(config, tmp_path / "paper.jsonl")
    assert [r for r in rows if r.outcome == "error"] == []
    assert {(r.model, r.task) for r in rows} == {(m.name, t) for m in config.models for t in ("T1", "T2")}
    assert all(r.true_success and r.believed_success for r in rows), [(r.model, r.task, r.reason) for r in rows]
    assert {r.api_key for r in fake.model_requests} == {"sk-paper"}  # the config's key reached every server
    bodies = {r.body["model"]: r.body for r in fake.model_requests}
    assert "seed" not in bodies["claude-sonnet-4-20250514"] and "seed" in bodies["gpt-4.1"]
    assert bodies["deepseek-v3.1"]["temperature"] == 0.6 and "temperature" not in bodies["gpt-4.1"]
    cost = {r.model: r.cost for r in rows if r.task == "T1"}
    assert cost["GPT-4.1"] is not None and cost["GPT-4.1"] > 0  # priced in LiteLLM's cost map
    assert cost["Qwen3 Coder"] is None and cost["DeepSeek V3.1"] is None  # local models: unknown
