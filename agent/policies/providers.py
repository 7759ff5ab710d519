"""The offline models (`offline`: scripted/..., replay/...) registered as LiteLLM custom providers,
for code that calls LiteLLM itself (`litellm.completion(model="scripted/planner", ...)`). robocog's
own model client answers them without LiteLLM (`offline.offline_turn`); the turns are the same.

Import this module only where LiteLLM is used: importing LiteLLM costs seconds.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

import litellm
from litellm import CustomLLM, ModelResponse
from litellm.types.utils import Choices, Message, Usage

from robocog.agent.policies.offline import (
    SCRIPTED_MODELS,
    OfflineModelError,
    next_message,
    prompt_chars,
    response,
)

litellm.suppress_debug_info = True  # no "Give Feedback / Get Help" banners on failed calls


def model_response(model: str, message: dict[str, Any], prompt_chars: int) -> ModelResponse:
    """LiteLLM's response carrying `message` (an OpenAI-style assistant message), with the offline
    models' token estimate."""
    offline = response(model, message, prompt_chars, None)
    return ModelResponse(
        model=model,
        created=int(time.time()),
        choices=[
            Choices(
                index=0,
                finish_reason=offline.choices[0].finish_reason,
                message=Message(role="assistant", content=message.get("content"), tool_calls=message.get("tool_calls")),
            )
        ],
        usage=Usage(
            prompt_tokens=offline.usage.prompt_tokens,
            completion_tokens=offline.usage.completion_tokens,
            total_tokens=offline.usage.total_tokens,
        ),
    )


def _litellm_turn(provider: str, model: str, messages: list, kwargs: dict[str, Any]) -> tuple[ModelResponse, float]:
    """The offline turn of `provider/model` (LiteLLM hands a custom provider the name without its
    prefix) as LiteLLM's response; its refusals as LiteLLM's 400."""
    name = model if model.startswith(f"{provider}/") else f"{provider}/{model}"
    params = kwargs.get("optional_params") or {}
    try:
        message, delay = next_message(name, messages, params)
    except OfflineModelError as exc:
        raise litellm.BadRequestError(message=str(exc), model=name, llm_provider=provider) from None
    return model_response(name, message, prompt_chars(messages)), delay


class ScriptedProvider(CustomLLM):
    """`scripted/<variant>`: the planner's decision as a tool call, after the turn's latency."""

    def completion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        response, delay = _litellm_turn("scripted", model, messages, kwargs)
        if delay:
            time.sleep(delay)
        return response

    async def acompletion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        response, delay = _litellm_turn("scripted", model, messages, kwargs)
        if delay:
            await asyncio.sleep(delay)
        return response


class ReplayProvider(CustomLLM):
    """`replay/PATH.jsonl`: the N-th recorded assistant turn for the N-th model call of a run."""

    def completion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        return _litellm_turn("replay", model, messages, kwargs)[0]

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
