"""How robocog configures LiteLLM (`model.configured_litellm`, `litellm_tuning`), and that the real
LiteLLM -> HTTP path against the loopback fake model service still yields the same usage, cost and
trace fields, and still calls a callback someone registers.

`complete()` spares LiteLLM pricing a model not in its cost map (whose cost it records as None
anyway) and the success logging for no callback, by wrapping `litellm.response_cost_calculator`
and `litellm.utils.dispatch_success_logging` (there is no public switch). These tests fail if
LiteLLM stops calling those names, or if a wrapper changes a figure.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import litellm
import litellm.utils
import pytest

from robocog.agent.client import litellm_tuning
from robocog.agent.client.model import PLACEHOLDER_KEY, assistant_message, complete, configured_litellm, usage
from robocog.agent.client.settings import AgentSettings
from tests.fake_llm import FakeLLM, Turn
from tests.fake_llm.pytest_fixture import fake_llm_fixture  # noqa: F401

pytestmark = pytest.mark.anyio
ROOT = Path(__file__).resolve().parents[2]

UNPRICED = ["openai/fake-model", "hosted_vllm/fake-model", "anthropic/claude-fake", "ollama_chat/fake-model"]
PRICED = {"openai/gpt-4o": "gpt-4o", "anthropic/claude-sonnet-4-5": "claude-sonnet-4-5"}
MESSAGES: list[dict[str, Any]] = [
    {"role": "system", "content": "You are a household robot."},
    {"role": "user", "content": "Put away all the items into the shelf."},
]
TOOLS = [
    {
        "type": "function",
        "function": {
            "name": "grab",
            "description": "Grab an object.",
            "parameters": {"type": "object", "properties": {"object": {"type": "string"}}, "required": ["object"]},
        },
    }
]
RAISED = "raised"
REPLY = Turn(tool_calls=[("grab", {"object": "mug"})], usage=(1000, 200))


@pytest.fixture
def calculator_calls(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Any]]:
    """What LiteLLM's cost calculator (robocog's wrapper of it) answered, call by call (`RAISED`:
    it raised, as it does for a model it cannot price)."""
    configured_litellm()
    wrapper = litellm.response_cost_calculator
    answers: list[Any] = []

    def spy(*args: Any, **kwargs: Any) -> Any:
        answers.append(RAISED)
        answers[-1] = wrapper(*args, **kwargs)
        return answers[-1]

    monkeypatch.setattr(litellm, "response_cost_calculator", spy)
    yield answers


def settings_for(server: FakeLLM, model: str) -> AgentSettings:
    return AgentSettings(model=model, api_base=server.api_base(model), retries=0)


async def defaults(server: FakeLLM, model: str) -> Any:
    """The same call through LiteLLM with its defaults (it prices the response)."""
    return await litellm.acompletion(
        model=model,
        messages=MESSAGES,
        tools=TOOLS,
        api_base=server.api_base(model),
        api_key=PLACEHOLDER_KEY,
        max_retries=0,
    )


@pytest.fixture
def dispatches(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[bool]]:
    """Each time LiteLLM dispatched its success logging: whether robocog's wrapper skipped it."""
    configured_litellm()
    wrapper = litellm.utils.dispatch_success_logging
    skipped: list[bool] = []

    def spy(*args: Any, **kwargs: Any) -> Any:
        skipped.append(litellm_tuning.unlogged_call.get())
        return wrapper(*args, **kwargs)

    monkeypatch.setattr(litellm.utils, "dispatch_success_logging", spy)
    yield skipped


def test_the_configuration_is_applied_once() -> None:
    lib = configured_litellm()
    assert lib.suppress_debug_info is True
    wrappers = (lib.response_cost_calculator, litellm.utils.dispatch_success_logging)
    assert all(getattr(w, "robocog_tuned", False) for w in wrappers)
    litellm_tuning.tune(lib)  # a second time wraps nothing more
    assert (lib.response_cost_calculator, litellm.utils.dispatch_success_logging) == wrappers
    # nothing registered to log to: LiteLLM's success and failure logging has no one to tell
    assert lib.success_callback == [] and lib._async_success_callback == []
    assert lib.failure_callback == [] and lib._async_failure_callback == []
    assert lib.callbacks == []
    assert lib.cache is None


@pytest.mark.parametrize("model", UNPRICED)
async def test_an_unpriced_model_is_not_priced_and_reads_the_same(
    fake_llm: FakeLLM, calculator_calls: list[Any], model: str
) -> None:
    fake_llm.reply(REPLY, REPLY)
    ours = await complete(settings_for(fake_llm, model), MESSAGES, TOOLS)
    # LiteLLM still asks its cost calculator (the name robocog wraps), which answers None at once
    assert calculator_calls and all(answer is None for answer in calculator_calls)
    if model.startswith("ollama_chat/"):  # pricing an unknown Ollama model asks the server about it
        assert [r.path for r in fake_llm.requests] == ["/api/chat"]
    calculator_calls.clear()
    theirs = await defaults(fake_llm, model)
    assert calculator_calls  # priced as LiteLLM always does: the wrapper is only for complete()'s calls
    assert usage(ours) == (1000, 200, None)
    assert usage(theirs)[:2] == (1000, 200)
    assert theirs._hidden_params.get("response_cost") in (None, 0.0)  # what complete() recorded as None
    mine, other = assistant_message(ours), assistant_message(theirs)
    assert mine["content"] == other["content"]
    assert [c["function"] for c in mine["tool_calls"]] == [c["function"] for c in other["tool_calls"]]


@pytest.mark.parametrize(("model", "price"), PRICED.items())
async def test_a_priced_model_is_priced_as_before(
    fake_llm: FakeLLM, calculator_calls: list[Any], model: str, price: str
) -> None:
    fake_llm.reply(REPLY, REPLY)
    ours = await complete(settings_for(fake_llm, model), MESSAGES, TOOLS)
    rates = litellm.model_cost[price]
    expected = 1000 * rates["input_cost_per_token"] + 200 * rates["output_cost_per_token"]
    assert usage(ours)[:2] == (1000, 200)
    assert usage(ours)[2] == pytest.approx(expected)
    assert calculator_calls and calculator_calls[0] == pytest.approx(expected)
    theirs = await defaults(fake_llm, model)
    assert usage(theirs) == usage(ours)


async def test_a_failed_call_leaves_later_calls_priced(fake_llm: FakeLLM, calculator_calls: list[Any]) -> None:
    from tests.fake_llm import Fail

    fake_llm.reply(Fail(400, "bad request"), REPLY)
    with pytest.raises(Exception, match="400"):
        await complete(settings_for(fake_llm, "openai/fake-model"), MESSAGES, TOOLS)
    assert not litellm_tuning.unpriced_call.get() and not litellm_tuning.unlogged_call.get()
    cost = usage(await defaults(fake_llm, "openai/gpt-4o"))[2]
    assert cost is not None and cost > 0


async def test_no_success_logging_for_no_callback(fake_llm: FakeLLM, dispatches: list[bool]) -> None:
    fake_llm.reply(REPLY, REPLY)
    await complete(settings_for(fake_llm, "openai/gpt-4o"), MESSAGES, TOOLS)
    assert dispatches == [True]  # LiteLLM dispatched it; robocog's wrapper returned at once
    await defaults(fake_llm, "openai/gpt-4o")
    assert dispatches == [True, False]  # any other caller gets LiteLLM's logging as it is


CALLBACK_CHECK = """
import asyncio, sys
import litellm
from litellm.integrations.custom_logger import CustomLogger
from robocog.agent.client.model import complete, usage
from robocog.agent.client.settings import AgentSettings
from tests.fake_llm import FakeLLM, Turn

class Recorder(CustomLogger):
    def __init__(self):
        super().__init__()
        self.costs = {}
    async def async_log_success_event(self, kwargs, response_obj, start_time, end_time):
        self.costs[response_obj.id] = kwargs.get("response_cost")

class Given(Recorder): ...
class Registered(Recorder): ...  # LiteLLM keeps one callback of a class

async def main():
    with FakeLLM([Turn(text="ok", usage=(1000, 200))] * 2) as fake:
        for given in (True, False):
            recorder = Given() if given else Registered()
            litellm.callbacks = [] if given else [recorder]
            params = {"callbacks": [recorder]} if given else {}
            settings = AgentSettings(model="openai/gpt-4o", api_base=fake.openai_base, params=params)
            response = await complete(settings, [{"role": "user", "content": "hi"}], [])
            while response.id not in recorder.costs:
                await asyncio.sleep(0.01)
            print(recorder.costs[response.id] == usage(response)[2] and usage(response)[2] > 0)

asyncio.run(asyncio.wait_for(main(), 60))
"""


def test_a_callback_is_still_called() -> None:
    """A callback registered in LiteLLM, or given in a model's params, is told of each call with its
    cost. In a process of its own: LiteLLM's async logging worker outlives each test's event loop
    and replays on the next one what it was left."""
    done = subprocess.run(
        [sys.executable, "-c", CALLBACK_CHECK], capture_output=True, text=True, timeout=120, cwd=ROOT, check=False
    )
    assert done.stdout.split() == ["True", "True"], done.stderr[-2000:]
