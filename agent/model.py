"""The model service: one LiteLLM call with retries, credentials, and what a response carries.

Import this module only where a model is called: importing LiteLLM costs seconds.
"""

from __future__ import annotations

import asyncio
import random
from typing import TYPE_CHECKING, Any

from robocog.shared.errors import ModelServiceError

if TYPE_CHECKING:
    from robocog.agent.loop import AgentSettings


def warm_up_litellm() -> None:
    """Import LiteLLM and make one offline call: the first call pays for its lazy machinery."""
    import contextlib

    with contextlib.suppress(Exception):  # a real failure shows on the first real call
        import litellm

        from robocog.agent.providers import register

        register()
        litellm.completion(model="scripted/refuser", messages=[{"role": "user", "content": "warm up"}])


def check_credentials(model: str, api_base: str | None) -> None:
    """Raise `ModelServiceError` naming the environment variable a cloud model needs and lacks."""
    if model.split("/", 1)[0] in ("scripted", "replay", "ollama", "ollama_chat") or api_base:
        return
    import litellm

    try:
        check = litellm.validate_environment(model=model)
    except Exception:  # an unknown provider: let the call itself say what is wrong
        return
    missing = check.get("missing_keys") or []
    if missing:
        raise ModelServiceError(f"model {model!r} needs {', '.join(missing)} set in the environment")


async def complete(settings: AgentSettings, messages: list[dict[str, Any]], tools: list[dict[str, Any]]) -> Any:
    """One model call with retries and backoff on rate limits, timeouts and server errors."""
    import litellm

    from robocog.agent.providers import register

    register()
    kwargs: dict[str, Any] = dict(settings.params)
    if settings.api_base:
        kwargs["api_base"] = settings.api_base
    if settings.seed is not None:
        kwargs["seed"] = settings.seed
    if settings.temperature is not None:
        kwargs["temperature"] = settings.temperature
    transient = (
        litellm.RateLimitError,
        litellm.Timeout,
        litellm.APIConnectionError,
        litellm.InternalServerError,
        litellm.ServiceUnavailableError,
    )
    for attempt in range(settings.retries + 1):
        try:
            return await litellm.acompletion(
                model=settings.model, messages=messages, tools=tools, timeout=settings.timeout_s, **kwargs
            )
        except litellm.AuthenticationError as exc:
            raise ModelServiceError(f"the model service refused the credentials: {exc}") from exc
        except transient as exc:
            if attempt == settings.retries:
                raise ModelServiceError(f"the model service kept failing ({type(exc).__name__}): {exc}") from exc
            await asyncio.sleep(min(30.0, settings.backoff_s * 2.0**attempt) * (0.5 + random.random()))
        except Exception as exc:  # a bad request, an unknown model...: not worth retrying
            raise ModelServiceError(f"the model call failed ({type(exc).__name__}): {exc}") from exc
    raise AssertionError("unreachable")


def assistant_message(response: Any) -> dict[str, Any]:
    msg = response.choices[0].message
    out: dict[str, Any] = {"role": "assistant", "content": msg.content}
    calls = getattr(msg, "tool_calls", None) or []
    if calls:
        out["tool_calls"] = [
            {
                "id": c.id or f"call_{i}",
                "type": "function",
                "function": {"name": c.function.name, "arguments": c.function.arguments or "{}"},
            }
            for i, c in enumerate(calls)
        ]
    return out


def usage(response: Any) -> tuple[int, int, float | None]:
    usage = getattr(response, "usage", None)
    tokens_in = int(getattr(usage, "prompt_tokens", 0) or 0)
    tokens_out = int(getattr(usage, "completion_tokens", 0) or 0)
    cost = None
    hidden = getattr(response, "_hidden_params", None) or {}
    if isinstance(hidden, dict) and hidden.get("response_cost") is not None:
        cost = float(hidden["response_cost"])
    return tokens_in, tokens_out, cost
