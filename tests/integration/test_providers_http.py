"""LiteLLM against real HTTP: the OpenAI, Anthropic and Ollama routes, driven through `tests.fake_llm`.

These tests call `litellm.acompletion` directly (not the agent loop), with LiteLLM's and the OpenAI
SDK's own retries off (`max_retries=0`), so each exchange is exactly one request. They pin what the
loop relies on: the shape of tool calls, usage and cost on each route, and which exception (with
which details) each HTTP failure becomes.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import httpx
import litellm
import pytest

from tests.fake_llm import PLACEHOLDER_KEY, Fail, FakeLLM, Turn, planner_script
from tests.fake_llm.pytest_fixture import fake_llm_fixture  # noqa: F401

pytestmark = pytest.mark.anyio

ROUTES = ["openai/fake-model", "anthropic/claude-fake", "ollama_chat/fake-model"]
PATH = {"openai": "/v1/chat/completions", "anthropic": "/v1/messages", "ollama_chat": "/api/chat"}

TASK = "Put away all the items into the shelf."
MESSAGES: list[dict[str, Any]] = [
    {"role": "system", "content": "You are a household robot."},
    {"role": "user", "content": TASK},
]
TOOLS = [
    {
        "type": "function",
        "function": {
            "name": "look_around",
            "description": "Describe the world.",
            "parameters": {"type": "object", "properties": {}},
        },
    },
    {
        "type": "function",
        "function": {
            "name": "grab",
            "description": "Grab an object.",
            "parameters": {"type": "object", "properties": {"object": {"type": "string"}}, "required": ["object"]},
        },
    },
]


@pytest.fixture(autouse=True)
def quiet_litellm(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No "Give Feedback / Get Help" banners, no client-side retries from the global settings."""
    monkeypatch.setattr(litellm, "suppress_debug_info", True)
    monkeypatch.setattr(litellm, "num_retries", None)
    monkeypatch.setattr(litellm, "drop_params", False)
    yield


async def call(server: FakeLLM, model: str, messages: list[dict[str, Any]] | None = None, **kwargs: Any) -> Any:
    """One completion against the fake server: placeholder key, no internal retries."""
    kwargs.setdefault("api_key", PLACEHOLDER_KEY)
    kwargs.setdefault("timeout", 5.0)
    return await litellm.acompletion(
        model=model,
        messages=messages or MESSAGES,
        tools=TOOLS,
        api_base=server.api_base(model),
        max_retries=0,
        **kwargs,
    )


def calls_of(response: Any) -> list[tuple[str, str, str]]:
    """(id, name, raw arguments) of each tool call in a response."""
    return [(c.id, c.function.name, c.function.arguments) for c in response.choices[0].message.tool_calls or []]


def assistant_message(response: Any) -> dict[str, Any]:
    """The response as the assistant message a loop appends to its history."""
    msg = response.choices[0].message
    out: dict[str, Any] = {"role": "assistant", "content": msg.content or None}
    if msg.tool_calls:
        out["tool_calls"] = [
            {"id": i, "type": "function", "function": {"name": n, "arguments": a}} for i, n, a in calls_of(response)
        ]
    return out


def sent_tool_names(server: FakeLLM) -> list[str]:
    tools = server.last.body["tools"]
    return [t["name"] if "name" in t else t["function"]["name"] for t in tools]


# --- turns ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_a_tool_call_turn(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(tool_calls=[("look_around", {})]))
    response = await call(fake_llm, model)
    [(call_id, name, arguments)] = calls_of(response)
    assert call_id and name == "look_around" and json.loads(arguments) == {}
    assert response.choices[0].finish_reason == "tool_calls"
    request = fake_llm.last
    assert request.path == PATH[model.split("/")[0]]
    assert request.body["model"] == model.split("/", 1)[1]
    assert sent_tool_names(fake_llm) == ["look_around", "grab"]
    assert request.neutral()[:2] == MESSAGES  # system prompt and task arrive, whatever the format


@pytest.mark.parametrize("model", ROUTES)
async def test_two_tool_calls_in_one_turn_and_their_results_go_back_paired(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(tool_calls=[("look_around", {}), ("grab", {"object": "mug"})]), Turn(text="Done."))
    first = await call(fake_llm, model)
    calls = calls_of(first)
    assert [(n, json.loads(a)) for _, n, a in calls] == [("look_around", {}), ("grab", {"object": "mug"})]
    assert len({i for i, _, _ in calls}) == 2  # distinct ids, even where the provider sends none (Ollama)
    history = [*MESSAGES, assistant_message(first)]
    history += [{"role": "tool", "tool_call_id": i, "content": json.dumps({"result": n})} for i, n, _ in calls]
    second = await call(fake_llm, model, history)
    assert second.choices[0].message.content == "Done."
    neutral = fake_llm.last.neutral()
    answered = {m["tool_call_id"]: json.loads(m["content"])["result"] for m in neutral if m["role"] == "tool"}
    asked = {c["id"]: c["function"]["name"] for m in neutral if m["role"] == "assistant" for c in m["tool_calls"]}
    assert answered == asked == {i: n for i, n, _ in calls}


@pytest.mark.parametrize("model", ["openai/fake-model", "ollama_chat/fake-model"])
async def test_malformed_arguments_arrive_intact(fake_llm: FakeLLM, model: str) -> None:
    raw = '{"object": "mug"'  # truncated JSON
    fake_llm.reply(Turn(tool_calls=[("grab", raw)]))
    [(_, name, arguments)] = calls_of(await call(fake_llm, model))
    assert (name, arguments) == ("grab", raw)


async def test_anthropic_tool_input_that_is_not_an_object_arrives_as_a_json_string(fake_llm: FakeLLM) -> None:
    # The Messages API always sends `input` as an object; if it were not one, LiteLLM JSON-encodes it,
    # so the loop sees valid JSON that is not an object (and must reject it as such).
    raw = '{"object": "mug"'
    fake_llm.reply(Turn(tool_calls=[("grab", raw)]))
    [(_, _, arguments)] = calls_of(await call(fake_llm, "anthropic/claude-fake"))
    assert json.loads(arguments) == raw


async def test_ollama_cannot_send_back_a_history_holding_malformed_arguments(fake_llm: FakeLLM) -> None:
    # LiteLLM json.loads every tool call of the history for Ollama: a malformed one fails the next
    # call on the client, before any request (as an APIConnectionError). A loop must keep only
    # parseable arguments in the history it sends.
    fake_llm.reply(Turn(tool_calls=[("grab", '{"object": "mug"')]), Turn(text="Done."))
    first = await call(fake_llm, "ollama_chat/fake-model")
    [(call_id, _, _)] = calls_of(first)
    history = [*MESSAGES, assistant_message(first), {"role": "tool", "tool_call_id": call_id, "content": "error"}]
    with pytest.raises(litellm.APIConnectionError):
        await call(fake_llm, "ollama_chat/fake-model", history)
    assert len(fake_llm.model_requests) == 1


@pytest.mark.parametrize("model", ROUTES)
async def test_a_text_only_turn(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(text="I believe the task is already done."))
    response = await call(fake_llm, model)
    assert response.choices[0].message.content == "I believe the task is already done."
    assert not response.choices[0].message.tool_calls
    assert response.choices[0].finish_reason == "stop"


# --- usage and cost ------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_usage_tokens_are_read_back(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(tool_calls=[("look_around", {})], usage=(1234, 56)))
    usage = (await call(fake_llm, model)).usage
    assert (usage.prompt_tokens, usage.completion_tokens, usage.total_tokens) == (1234, 56, 1290)


@pytest.mark.parametrize(
    ("model", "price"),
    [
        ("openai/gpt-4o", "gpt-4o"),
        ("anthropic/claude-sonnet-4-5", "claude-sonnet-4-5"),
        ("openai/fake-model", None),
        ("anthropic/claude-fake", None),
    ],
)
async def test_cost_comes_from_the_local_cost_map_or_is_none(fake_llm: FakeLLM, model: str, price: str | None) -> None:
    fake_llm.reply(Turn(text="ok", usage=(1000, 200)))
    cost = (await call(fake_llm, model))._hidden_params.get("response_cost")
    if price is None:
        assert cost is None
    else:
        rates = litellm.model_cost[price]
        assert cost == pytest.approx(1000 * rates["input_cost_per_token"] + 200 * rates["output_cost_per_token"])


async def test_ollama_models_cost_zero_not_none(fake_llm: FakeLLM) -> None:
    # For a model missing from the cost map, LiteLLM asks the server (POST /api/show) and prices it at 0.
    fake_llm.reply(Turn(text="ok", usage=(1000, 200)))
    response = await call(fake_llm, "ollama_chat/fake-model")
    assert response._hidden_params.get("response_cost") == 0.0


# --- failures ------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_401_raises_authentication_error(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Fail(401, "invalid api key"))
    with pytest.raises(litellm.AuthenticationError) as caught:
        await call(fake_llm, model)
    assert caught.value.status_code == 401 and "invalid api key" in str(caught.value)
    assert len(fake_llm.model_requests) == 1


@pytest.mark.parametrize("model", ROUTES)
async def test_429_raises_rate_limit_error_with_retry_after(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Fail(429, "slow down", headers={"Retry-After": "7"}))
    started = time.monotonic()
    with pytest.raises(litellm.RateLimitError) as caught:
        await call(fake_llm, model)
    assert time.monotonic() - started < 2  # nobody waited the 7 s: no retry inside LiteLLM or the SDK
    assert len(fake_llm.model_requests) == 1
    # The provider's headers: httpx.Headers on the OpenAI and Anthropic routes, a plain dict (lower-case
    # names) on Ollama's; `exc.response` is a synthetic response without them.
    headers = httpx.Headers(getattr(caught.value, "litellm_response_headers", None) or {})
    assert headers.get("retry-after") == "7"


@pytest.mark.parametrize("model", ROUTES)
async def test_500_raises_internal_server_error(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Fail(500, "boom"))
    with pytest.raises(litellm.InternalServerError) as caught:
        await call(fake_llm, model)
    assert caught.value.status_code == 500
    assert len(fake_llm.model_requests) == 1


@pytest.mark.parametrize("model", ROUTES)
async def test_400_raises_bad_request_error(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Fail(400, "context too long"))
    with pytest.raises(litellm.BadRequestError):
        await call(fake_llm, model)
    assert len(fake_llm.model_requests) == 1


@pytest.mark.parametrize("model", ROUTES)
async def test_a_slow_server_raises_timeout(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(text="too late", delay=1.5))
    started = time.monotonic()
    with pytest.raises(litellm.Timeout):
        await call(fake_llm, model, timeout=0.3)
    assert time.monotonic() - started < 1.2
    assert len(fake_llm.model_requests) == 1


# --- parameters and keys -------------------------------------------------------------------------


async def test_anthropic_rejects_seed_unless_params_are_dropped(fake_llm: FakeLLM) -> None:
    model = "anthropic/claude-fake"
    fake_llm.reply(Turn(text="ok"))
    with pytest.raises(litellm.UnsupportedParamsError):
        await call(fake_llm, model, seed=7, temperature=0.6)
    assert fake_llm.model_requests == []  # refused before any request
    await call(fake_llm, model, seed=7, temperature=0.6, drop_params=True)
    body = fake_llm.last.body
    assert "seed" not in body and body["temperature"] == 0.6
    # What drop_params drops can be known beforehand:
    supported = litellm.get_supported_openai_params(model="claude-fake", custom_llm_provider="anthropic") or []
    assert "seed" not in supported and "temperature" in supported


@pytest.mark.parametrize("model", ["openai/fake-model", "ollama_chat/fake-model"])
async def test_seed_and_temperature_reach_the_other_routes(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.reply(Turn(text="ok"))
    await call(fake_llm, model, seed=7, temperature=0.6, drop_params=True)
    body = fake_llm.last.body
    sampled = body.get("options", body)  # Ollama puts them under "options"
    assert (sampled["seed"], sampled["temperature"]) == (7, 0.6)


@pytest.mark.parametrize(
    ("model", "header", "value"),
    [
        ("openai/fake-model", "authorization", f"Bearer {PLACEHOLDER_KEY}"),
        ("anthropic/claude-fake", "x-api-key", PLACEHOLDER_KEY),
        ("ollama_chat/fake-model", "authorization", f"Bearer {PLACEHOLDER_KEY}"),
    ],
)
async def test_a_placeholder_key_reaches_a_keyless_server(
    fake_llm: FakeLLM, model: str, header: str, value: str
) -> None:
    fake_llm.reply(Turn(text="ok"))
    await call(fake_llm, model)
    assert fake_llm.last.headers[header] == value


@pytest.mark.parametrize(
    ("model", "error"),
    [("openai/fake-model", litellm.InternalServerError), ("anthropic/claude-fake", litellm.AuthenticationError)],
)
async def test_without_a_key_openai_and_anthropic_fail_before_any_request(
    fake_llm: FakeLLM, model: str, error: type[Exception], monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in ("OPENAI_API_KEY", "ANTHROPIC_API_KEY", "ANTHROPIC_AUTH_TOKEN"):
        monkeypatch.delenv(name, raising=False)
    fake_llm.reply(Turn(text="ok"))
    with pytest.raises(error) as caught:
        await call(fake_llm, model, api_key=None)
    # OpenAI's "Missing credentials" comes out as an InternalServerError: a retrying loop must not retry it.
    assert "Missing" in str(caught.value)
    assert fake_llm.model_requests == []


async def test_ollama_needs_no_key(fake_llm: FakeLLM, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OLLAMA_API_KEY", raising=False)
    fake_llm.reply(Turn(text="ok"))
    response = await call(fake_llm, "ollama_chat/fake-model", api_key=None)
    assert response.choices[0].message.content == "ok"
    assert "authorization" not in fake_llm.last.headers


async def test_failed_calls_print_no_banner(fake_llm: FakeLLM, capfd: pytest.CaptureFixture[str]) -> None:
    fake_llm.reply(Fail(500, "boom"), Fail(500, "boom"))
    with pytest.raises(litellm.InternalServerError):
        await call(fake_llm, "anthropic/claude-fake")
    assert capfd.readouterr() == ("", "")
    litellm.suppress_debug_info = False  # restored by the autouse fixture
    with pytest.raises(litellm.InternalServerError):
        await call(fake_llm, "anthropic/claude-fake")
    assert "Give Feedback / Get Help" in capfd.readouterr().out


# --- the planner, replayed over HTTP -------------------------------------------------------------


@pytest.mark.parametrize("model", ROUTES)
async def test_the_planner_decides_from_what_each_route_sends(fake_llm: FakeLLM, model: str) -> None:
    fake_llm.script = planner_script()
    first = await call(fake_llm, model)
    [(call_id, name, arguments)] = calls_of(first)
    assert (name, json.loads(arguments)) == ("search_memory", {"query": TASK})
    history = [*MESSAGES, assistant_message(first)]
    history.append({"role": "tool", "tool_call_id": call_id, "content": json.dumps({"results": []})})
    [(_, name, _)] = calls_of(await call(fake_llm, model, history))
    assert name == "look_around"  # it read its memory search back: the conversation survived the route
