"""Real model routes, over real HTTP: the agent loop against `tests.fake_llm` and a real robot server.

The fake model service speaks the OpenAI, Anthropic and Ollama APIs on loopback; the planner's
decisions are replayed through it (`planner_script`), so a full T1 runs through each LiteLLM route
and the robot's ground truth judges it. Failures are scripted (401, 429 with Retry-After, 500,
timeouts) and must come out as the attempt's outcome "error" with the provider's message on one
line, retried only when a retry can help.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import litellm
import pytest

from robocog.agent.client import model as model_service
from robocog.agent.client import model_errors
from robocog.agent.client.connection import Robot, ServerSpec, connect
from robocog.agent.client.loop import EpisodeResult, run_episode
from robocog.agent.client.model import PLACEHOLDER_KEY, check_credentials, complete, resolve_api_key
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.errors import ModelServiceError
from robocog.shared.evaluation import ModelSpec
from robocog.shared.trace import ModelTurn, ToolResult
from tests.fake_llm import Fail, FakeLLM, Reply, Request, Turn, planner_script
from tests.helpers import ROOT

pytestmark = pytest.mark.anyio

ROUTES = ["openai/fake-model", "anthropic/claude-fake", "ollama_chat/fake-model"]
KEY_VARIABLES = ("OPENAI_API_KEY", "ANTHROPIC_API_KEY", "ANTHROPIC_AUTH_TOKEN", "OLLAMA_API_KEY")
HELLO = [{"role": "user", "content": "Hello."}]
END = ("end_task", {"status": "success", "description": "T1", "summary": "done"})


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    """Module scope, so that one robot server serves every test here."""
    return "asyncio"


@pytest.fixture(scope="module")
def fake() -> Iterator[FakeLLM]:
    with FakeLLM() as server:
        yield server


@pytest.fixture(scope="module")
async def robot(tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[Robot]:
    """The real `robocog-server --profile eval`, spawned over stdio once for the module."""
    data = tmp_path_factory.mktemp("memory")
    async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(data)])) as robot:
        yield robot


@pytest.fixture(autouse=True)
def fresh(fake: FakeLLM, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No key in the environment, no notice said yet, the fake server's record empty."""
    for name in KEY_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(model_service, "_noticed", set())
    fake.reset()
    fake.script = None
    yield
    assert not fake.problems, fake.problems


async def episode(robot: Robot, settings: AgentSettings, trace: Trace | None = None) -> tuple[EpisodeResult, bool]:
    """T1 from a fresh world and an empty memory; the result and the ground truth."""
    await robot.client.call_tool("clear_memory", {})
    await robot.client.call_tool("reset_world", {})
    result = await run_episode(
        robot.client,
        robot.tasks["T1"],
        settings,
        trace or Trace(),
        system_prompt=robot.system_prompt,
        tools=robot.tools,
    )
    checked = await robot.client.call_tool("check_task", {"task_id": "T1"})
    return result, bool((checked.structured_content or {}).get("success"))


def sampled(request: Request) -> dict[str, Any]:
    """The sampling parameters of a request (Ollama puts them under "options")."""
    body = request.body
    return dict(body.get("options", {})) if "options" in body else body


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


# --- failures: outcome "error", never a refusal --------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_a_provider_500_on_every_call_is_an_error_after_the_retries(
    robot: Robot, fake: FakeLLM, model: str
) -> None:
    fake.script = lambda request: Fail(500, "the service is down")
    settings = AgentSettings(model=model, api_base=fake.api_base(model), retries=2, backoff_s=0.01)
    started = time.monotonic()
    result, truth = await episode(robot, settings)
    assert time.monotonic() - started < 5
    assert (result.outcome, result.believed_success, result.tool_calls, truth) == ("error", None, 0, False)
    assert not result.stopped  # an outage is not a refusal
    assert result.error is not None and "\n" not in result.error
    assert f"{model} answered 500 (server error): the service is down (after 3 attempts)" in result.error
    assert len(fake.model_requests) == 3


@pytest.mark.parametrize("model", ROUTES)
async def test_a_401_is_an_error_at_once_with_the_providers_message(robot: Robot, fake: FakeLLM, model: str) -> None:
    fake.script = lambda request: Fail(401, "invalid x-api-key")
    result, _ = await episode(robot, AgentSettings(model=model, api_base=fake.api_base(model), api_key="sk-wrong"))
    assert result.outcome == "error"
    assert result.error == f"ModelServiceError: {model} answered 401 (authentication): invalid x-api-key"
    assert len(fake.model_requests) == 1  # never retried
    assert fake.last.api_key == "sk-wrong"  # the key given is the key sent


@pytest.mark.parametrize("model", ROUTES)
@pytest.mark.parametrize(
    ("fail", "expected", "retried"),
    [
        (Fail(400, "prompt is too long"), "answered 400 (bad request): prompt is too long", False),
        (Fail(403, "not allowed"), "answered 403 (permission denied): not allowed", False),
        (Fail(404, "no such model"), "answered 404 (not found): no such model", False),
        (Fail(503, "try later"), "answered 503 (unavailable): try later", True),
    ],
    ids=["400", "403", "404", "503"],
)
async def test_each_routes_failures_read_as_one_line_with_the_providers_message(
    fake: FakeLLM, model: str, fail: Fail, expected: str, retried: bool
) -> None:
    fake.script = lambda request: fail
    with pytest.raises(ModelServiceError) as caught:
        await complete(AgentSettings(model=model, api_base=fake.api_base(model), retries=1, backoff_s=0.01), HELLO, [])
    assert str(caught.value) == f"{model} {expected}" + (" (after 2 attempts)" if retried else "")
    assert len(fake.model_requests) == (2 if retried else 1)


@pytest.mark.parametrize("model", ROUTES)
async def test_a_429_waits_what_retry_after_says(robot: Robot, fake: FakeLLM, model: str) -> None:
    replies: Iterator[Reply] = iter([Fail(429, "slow down", headers={"Retry-After": "1"}), Turn(tool_calls=[END])])
    fake.script = lambda request: next(replies)
    # A backoff of 10 s (5-15 s with jitter) would show: the wait must be the provider's 1 s.
    settings = AgentSettings(model=model, api_base=fake.api_base(model), backoff_s=10.0)
    result, _ = await episode(robot, settings)
    assert result.outcome == "ended" and result.error is None
    first, second = fake.model_requests
    assert 0.95 <= second.received - first.received < 2.5


async def test_a_429_without_retry_after_backs_off_with_jitter(fake: FakeLLM) -> None:
    model = "openai/fake-model"
    fake.reply(Fail(429, "slow down"), Turn(text="ok"))
    await complete(AgentSettings(model=model, api_base=fake.api_base(model), backoff_s=0.2), HELLO, [])
    first, second = fake.model_requests
    assert 0.1 <= second.received - first.received < 1.0  # 0.2 s x (0.5 .. 1.5), not at once


async def test_retry_after_is_capped(fake: FakeLLM, monkeypatch: pytest.MonkeyPatch) -> None:
    waits: list[float] = []

    async def no_sleep(seconds: float) -> None:
        waits.append(seconds)

    monkeypatch.setattr(asyncio, "sleep", no_sleep)
    model = "anthropic/claude-fake"
    fake.reply(Fail(429, "slow down", headers={"Retry-After": "3600"}), Turn(text="ok"))
    await complete(AgentSettings(model=model, api_base=fake.api_base(model)), HELLO, [])
    assert waits == [model_errors.MAX_RETRY_AFTER_S]


async def test_a_timeout_is_retried_then_an_error(robot: Robot, fake: FakeLLM) -> None:
    model = "openai/fake-model"
    fake.script = lambda request: Turn(text="too late", delay=2.0)
    settings = AgentSettings(model=model, api_base=fake.api_base(model), timeout_s=0.3, retries=1, backoff_s=0.01)
    result, _ = await episode(robot, settings)
    assert result.outcome == "error"
    assert result.error == f"ModelServiceError: {model} did not answer within 0.3 s (after 2 attempts)"
    assert len(fake.model_requests) == 2


async def test_a_refused_connection_names_the_server(robot: Robot) -> None:
    settings = AgentSettings(model="openai/fake-model", api_base="http://127.0.0.1:9/v1", retries=1, backoff_s=0.01)
    result, _ = await episode(robot, settings)
    assert result.outcome == "error" and result.error is not None
    assert "could not be reached at http://127.0.0.1:9/v1" in result.error and "\n" not in result.error


async def test_a_cloud_model_without_a_key_is_an_error_before_any_request(robot: Robot) -> None:
    with pytest.raises(ModelServiceError, match="OPENAI_API_KEY"):
        check_credentials("gpt-4.1", None)
    result, _ = await episode(robot, AgentSettings(model="gpt-4.1", retries=3, backoff_s=5.0))
    assert result.outcome == "error"  # at once: "Missing credentials" is not a server error to retry
    assert result.error == "ModelServiceError: gpt-4.1 has no API key: set OPENAI_API_KEY or give --api-key"


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        ("litellm.AuthenticationError: AuthenticationError: OpenAIException - invalid key", "invalid key"),
        (
            'litellm.InternalServerError: AnthropicException - {"type": "error", "error": {"type": "api_error", '
            '"message": "boom"}}. Handle with `litellm.InternalServerError`.',
            "boom",
        ),
        ("litellm.BadRequestError: OpenAIException - Error code: 400 - {'error': {'message': 'too long'}}", "too long"),
        ("litellm.APIConnectionError: Ollama_chatException - bad\nTraceback (most recent call last):\n  x", "bad"),
        ('litellm.RateLimitError: Ollama_chatException - {"error": "slow\\ndown"}', "slow down"),
    ],
)
def test_the_providers_message_is_read_out_of_litellms_wrapping(raw: str, message: str) -> None:
    assert model_errors.provider_message(Exception(raw)) == message


def test_retry_after_reads_seconds_milliseconds_and_dates() -> None:
    from email.utils import formatdate

    class Limited(Exception):
        def __init__(self, headers: dict[str, str]) -> None:
            self.litellm_response_headers = headers

    assert model_errors.retry_after(Limited({"Retry-After": "7"})) == 7.0
    assert model_errors.retry_after(Limited({"retry-after-ms": "1500"})) == 1.5
    in_ten = model_errors.retry_after(Limited({"Retry-After": formatdate(time.time() + 10, usegmt=True)}))
    assert in_ten is not None and 8 < in_ten <= 10
    assert model_errors.retry_after(Limited({})) is None


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


# --- keys ----------------------------------------------------------------------------------------


def test_credentials_are_not_checked_when_a_key_or_a_server_is_given() -> None:
    with pytest.raises(ModelServiceError, match="ANTHROPIC_API_KEY"):
        check_credentials("anthropic/claude-sonnet-4-20250514", None)
    check_credentials("anthropic/claude-sonnet-4-20250514", None, "sk-ant-given")
    check_credentials("openai/local", "http://127.0.0.1:8000/v1")
    check_credentials("ollama_chat/qwen3", None)
    check_credentials("scripted/planner", None)


def test_a_study_models_key_comes_from_the_config_or_the_variable_it_names(monkeypatch: pytest.MonkeyPatch) -> None:
    assert resolve_api_key(ModelSpec(model="gpt-4.1", api_key="sk-inline")) == "sk-inline"
    assert resolve_api_key(ModelSpec(model="gpt-4.1")) is None
    monkeypatch.setenv("ROBOCOG_TEST_KEY", "sk-from-env")
    assert resolve_api_key(ModelSpec(model="gpt-4.1", api_key_env="ROBOCOG_TEST_KEY")) == "sk-from-env"
    monkeypatch.delenv("ROBOCOG_TEST_KEY")
    with pytest.raises(ModelServiceError, match="ROBOCOG_TEST_KEY, which is not set"):
        resolve_api_key(ModelSpec(model="gpt-4.1", label="GPT", api_key_env="ROBOCOG_TEST_KEY"))


async def test_a_key_in_the_environment_is_kept_for_a_server_given_by_api_base(
    fake: FakeLLM, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("OPENAI_API_KEY", "sk-proxy")  # e.g. a proxy that takes the usual key
    model = "openai/fake-model"
    fake.reply(Turn(text="ok"))
    await complete(AgentSettings(model=model, api_base=fake.api_base(model)), HELLO, [])
    assert fake.last.api_key == "sk-proxy"


# --- the command line ----------------------------------------------------------------------------


def test_robocog_run_with_a_refused_key_prints_one_line_and_fails(fake: FakeLLM, tmp_path: Path) -> None:
    fake.script = lambda request: Fail(401, "invalid api key")
    env = {k: v for k, v in os.environ.items() if k not in KEY_VARIABLES}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "robocog.agent.cli",
            "run",
            "T1",
            "--model",
            "openai/fake-model",
            "--api-base",
            fake.api_base("openai/fake-model"),
            "--api-key",
            "sk-given",
            "--quiet",
            "--data-dir",
            str(tmp_path / "memory"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
        env=env,
    )
    assert done.returncode != 0
    assert [line for line in done.stderr.splitlines() if line.startswith("robocog:")] == [
        "robocog: ModelServiceError: openai/fake-model answered 401 (authentication): invalid api key"
    ], done.stderr
    assert "Give Feedback" not in done.stdout + done.stderr
    assert [r.api_key for r in fake.model_requests] == ["sk-given"]


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
