"""Model-service failures, over real HTTP against `tests.fake_llm` and a real robot server.

Failures are scripted (401, 429 with Retry-After, 500, timeouts) and must come out as the attempt's
outcome "error" with the provider's message on one line, retried only when a retry can help (the
same 500 twice is deterministic: tests/e2e/test_local_servers.py); keys
are checked before any request, and `robocog run` with a refused key prints one line and fails.
The shared setup is in tests/e2e/model_routes.py and model_route_fixtures.py.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from robocog.agent.client import model_errors
from robocog.agent.client.connection import Robot
from robocog.agent.client.model import check_credentials, complete, resolve_api_key
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.errors import ModelServiceError
from robocog.shared.evaluation import ModelSpec
from robocog.shared.trace import ModelTurn
from tests.e2e.model_route_fixtures import anyio_backend_fixture, fake_fixture, fresh_fixture, robot_fixture  # noqa: F401
from tests.e2e.model_routes import END, HELLO, KEY_VARIABLES, ROUTES, episode
from tests.fake_llm import Fail, FakeLLM, Reply, Turn

pytestmark = pytest.mark.anyio


# --- failures: outcome "error", never a refusal --------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_a_provider_500_on_every_call_is_an_error_after_the_retries(
    robot: Robot, fake: FakeLLM, model: str
) -> None:
    # Each answer in other words (a queue's position, say): transient, so retried to the end.
    fake.script = lambda request: Fail(500, f"the service is down ({len(fake.model_requests)})")
    settings = AgentSettings(model=model, api_base=fake.api_base(model), retries=2, backoff_s=0.01)
    started = time.monotonic()
    result, truth = await episode(robot, settings)
    assert time.monotonic() - started < 5
    assert (result.outcome, result.believed_success, result.tool_calls, truth) == ("error", None, 0, False)
    assert not result.stopped  # an outage is not a refusal
    assert result.error is not None and "\n" not in result.error
    assert f"{model} answered 500 (server error): the service is down (3) (after 3 attempts)" in result.error
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
    trace = Trace()
    result, _ = await episode(robot, settings, trace)
    assert result.outcome == "ended" and result.error is None
    first, second = fake.model_requests
    assert 0.95 <= second.received - first.received < 2.5
    # The turn keeps what the retry cost it (the failed call and the wait): part of its latency.
    (turn,) = [e for e in trace.events if isinstance(e, ModelTurn)]
    assert turn.retries == 1 and 0.95 <= turn.retry_s <= turn.latency_s


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
    problems = [line for line in done.stderr.splitlines() if line.startswith("robocog:")]
    assert problems[0].startswith("robocog: memory: ")  # each run names its memory first (informational)
    assert problems[1:] == [
        "robocog: ModelServiceError: openai/fake-model answered 401 (authentication): invalid api key"
    ], done.stderr
    assert "Give Feedback" not in done.stdout + done.stderr
    assert [r.api_key for r in fake.model_requests] == ["sk-given"]
