"""Offline "models" registered as LiteLLM custom providers, so they run through the same loop.

- `scripted/planner`: the symbolic planner (the no-key default and the optimal baseline).
- `scripted/overconfident`: sometimes forgets an object and still reports success. The probability
  is `scripted/overconfident` with `p` in the completion parameters (default 0.3), seeded by `seed`.
- `scripted/refuser`: never acts and never ends the task.
- Each scripted model takes `latency_s` (seconds per model turn, default 0) and `jitter_s` (a
  uniform draw in [-jitter_s, +jitter_s] added to it, seeded by `seed` and the turn's number, so
  reproducible) in the completion parameters: a study runs "as if" each turn took real time. The
  wait is `asyncio.sleep` in `acompletion` (episodes in flight overlap their waits) and `time.sleep`
  in `completion`; it changes the timing of a run, never its decisions.
- `replay/PATH.jsonl`: replays the assistant turns recorded in a trace file, in order.

Import this module only where LiteLLM is used: importing LiteLLM costs seconds.
"""

from __future__ import annotations

import asyncio
import json
import math
import random
import time
from functools import cache
from pathlib import Path
from typing import Any

import litellm
from litellm import CustomLLM, ModelResponse
from litellm.types.utils import Choices, Message, Usage

from robocog.agent.policies.belief import as_dict
from robocog.agent.policies.planner import VARIANTS, Call, decide, is_variant
from robocog.shared.trace import ModelTurn, read_trace

litellm.suppress_debug_info = True  # no "Give Feedback / Get Help" banners on failed calls

SCRIPTED_MODELS = VARIANTS


def _response(model: str, message: dict[str, Any], prompt_chars: int) -> ModelResponse:
    tool_calls = message.get("tool_calls") or None
    completion_chars = len(json.dumps(message))
    return ModelResponse(
        model=model,
        created=int(time.time()),
        choices=[
            Choices(
                index=0,
                finish_reason="tool_calls" if tool_calls else "stop",
                message=Message(role="assistant", content=message.get("content"), tool_calls=tool_calls),
            )
        ],
        # An estimate (4 characters a token): these models read no tokens, but reports stay comparable.
        usage=Usage(
            prompt_tokens=prompt_chars // 4,
            completion_tokens=completion_chars // 4,
            total_tokens=(prompt_chars + completion_chars) // 4,
        ),
    )


def _prompt_chars(messages: list[Any]) -> int:
    return sum(len(json.dumps(m, default=str)) for m in messages)


def call_message(call: Call, call_number: int) -> dict[str, Any]:
    """The assistant message carrying the planner's decision."""
    if call.name is None:
        return {"role": "assistant", "content": call.text}
    return {
        "role": "assistant",
        "content": None,
        "tool_calls": [
            {
                "id": f"call_{call_number}",
                "type": "function",
                "function": {"name": call.name, "arguments": json.dumps(call.arguments)},
            }
        ],
    }


def _seconds(params: dict[str, Any], name: str, model: str) -> float:
    """A non-negative, finite number of seconds from the completion parameters (0 when absent)."""
    value = params.get(name, (params.get("extra_body") or {}).get(name, 0.0))
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds >= 0):
        raise litellm.BadRequestError(
            message=f"{model}: {name} must be a non-negative number of seconds, not {value!r}",
            model=model,
            llm_provider="scripted",
        )
    return seconds


def turn_delay(latency_s: float, jitter_s: float, seed: int | None, turn: int) -> float:
    """How long model turn `turn` (1, 2, ...) of a scripted model takes: `latency_s` plus a uniform
    draw in [-jitter_s, +jitter_s] (never below 0), the same for the same seed and turn. The draw
    has its own generator: the model's decisions do not depend on the latency."""
    if not jitter_s:
        return latency_s
    draw = random.Random(f"latency:{seed}:{turn}").uniform(-jitter_s, jitter_s)
    return max(0.0, latency_s + draw)


class ScriptedProvider(CustomLLM):
    """`scripted/<variant>`: the planner's decision as a tool call, after the turn's latency."""

    def completion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        response, delay = self._turn(model, messages, kwargs)
        if delay:
            time.sleep(delay)
        return response

    async def acompletion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        response, delay = self._turn(model, messages, kwargs)
        if delay:
            await asyncio.sleep(delay)
        return response

    def _turn(self, model: str, messages: list, kwargs: dict[str, Any]) -> tuple[ModelResponse, float]:
        """The response to `messages` and how long to wait before giving it."""
        variant = model.split("/")[-1]
        if not is_variant(variant):
            raise litellm.BadRequestError(
                message=f"unknown scripted model {model!r}; use one of "
                + ", ".join(f"scripted/{v}" for v in SCRIPTED_MODELS),
                model=model,
                llm_provider="scripted",
            )
        params = kwargs.get("optional_params") or {}
        seed = params.get("seed")
        p = float(params.get("p", (params.get("extra_body") or {}).get("p", 0.3)))
        latency_s, jitter_s = _seconds(params, "latency_s", model), _seconds(params, "jitter_s", model)
        assistant = [m for m in map(as_dict, messages) if m.get("role") == "assistant"]
        calls_so_far = sum(len(m.get("tool_calls") or []) for m in assistant)
        call = decide(messages, variant, seed=seed, p=p)
        response = _response(f"scripted/{variant}", call_message(call, calls_so_far + 1), _prompt_chars(messages))
        return response, turn_delay(latency_s, jitter_s, seed, len(assistant) + 1)


@cache
def _recorded_turns(path: str) -> list[dict[str, Any]]:
    turns = [e.message for e in read_trace(Path(path)) if isinstance(e, ModelTurn)]
    if not turns:
        raise ValueError(f"{path}: the trace holds no model turns to replay")
    return turns


class ReplayProvider(CustomLLM):
    """`replay/PATH.jsonl`: the N-th recorded assistant turn for the N-th model call of a run."""

    def completion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        path = model.split("/", 1)[1] if model.startswith("replay/") else model
        try:
            turns = _recorded_turns(path)
        except FileNotFoundError:
            raise litellm.BadRequestError(
                message=f"replay: no trace file {path!r}", model=model, llm_provider="replay"
            ) from None
        index = sum(1 for m in map(as_dict, messages) if m.get("role") == "assistant")
        if index >= len(turns):
            message: dict[str, Any] = {"role": "assistant", "content": "(the recorded run has no more turns)"}
        else:
            message = turns[index]
        return _response(f"replay/{path}", message, _prompt_chars(messages))

    async def acompletion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        return self.completion(model, messages, *args, **kwargs)


_registered = False


def register() -> None:
    """Make `scripted/...` and `replay/...` model strings known to LiteLLM (once per process)."""
    global _registered
    if _registered:
        return
    _registered = True
    known = {item["provider"] for item in litellm.custom_provider_map}
    if "scripted" not in known:
        litellm.custom_provider_map.append({"provider": "scripted", "custom_handler": ScriptedProvider()})
    if "replay" not in known:
        litellm.custom_provider_map.append({"provider": "replay", "custom_handler": ReplayProvider()})
    from litellm.utils import custom_llm_setup

    custom_llm_setup()
    # They cost nothing; saying so also spares LiteLLM a pricing search on every call.
    free = {
        "input_cost_per_token": 0.0,
        "output_cost_per_token": 0.0,
        "cache_creation_input_token_cost": 0.0,
        "cache_read_input_token_cost": 0.0,
        "mode": "chat",
    }
    litellm.register_model({f"scripted/{v}": {**free, "litellm_provider": "scripted"} for v in SCRIPTED_MODELS})
