"""The model service: one LiteLLM call with retries, credentials, and what a response carries.

What `complete()` guarantees, whatever the provider:

- Only parameters the provider takes are sent (LiteLLM's `drop_params`); what is left out is named
  once per process on stderr ("robocog: anthropic/... does not take 'seed'; it is not sent").
- One request per attempt (LiteLLM's and the OpenAI SDK's own retries are off): this loop is the
  only retrier. Authentication, permission and bad-request errors are never retried; a rate limit
  waits what the provider's `Retry-After` says (capped), else backs off with jitter; server errors,
  timeouts and connection errors back off and try again.
- A server error is retried only while it may be transient: the same status and body twice (a
  template that cannot render the history answers so every time) ends the calls at the second.
- Every failure is a `ModelServiceError` whose message is one line carrying the provider's own
  words: "anthropic/claude-sonnet-4-20250514 answered 401 (authentication): invalid x-api-key".
- What local servers need of a request is adapted here, in `sendable_request` (see there).
- With `api_base` and no key at all, a placeholder key is sent, so keyless local servers
  (llama.cpp, vLLM, LM Studio) work.
- The cost of a turn comes from LiteLLM's local cost map when the model is in it, else it is None:
  never a guess (LiteLLM prices unknown Ollama models at 0.0; that becomes None here). For a model
  not in the map LiteLLM is not asked to price the turn at all (`litellm_tuning`).

The offline models (`scripted/...`, `replay/...`) are answered in-process
(`robocog.agent.policies.offline`), without LiteLLM: a scripted run never imports it.

Import this module only where a model is called: importing LiteLLM costs seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import time
from collections.abc import Iterable
from functools import cache
from typing import TYPE_CHECKING, Any

from robocog.agent.client import compat
from robocog.agent.client.litellm_tuning import robocog_call, tune
from robocog.agent.client.local_servers import OPENAI_COMPATIBLE, bounded
from robocog.agent.client.model_errors import Retries, classify, missing_keys
from robocog.agent.client.model_names import missing_key, quick_verdict
from robocog.agent.policies.offline import OfflineModelError, is_offline, offline_turn
from robocog.shared.errors import ModelServiceError

if TYPE_CHECKING:
    from robocog.agent.client.settings import AgentSettings
    from robocog.shared.evaluation import ModelSpec

#: The key sent to a server given by `api_base` when no key is given or set (keyless local servers).
PLACEHOLDER_KEY = "sk-no-key-required"
#: Routes that need no key: the offline models and Ollama.
KEYLESS_ROUTES = frozenset({"scripted", "replay", "ollama", "ollama_chat"})

# --- LiteLLM, once -------------------------------------------------------------------------------


_configured = False


def configured_litellm() -> Any:
    """LiteLLM, configured once per process: no banners, the offline models registered, and what it
    does on every call that does nothing for `complete()`'s calls turned off for them
    (`litellm_tuning`: no pricing of a model it cannot price, no logging for no callback)."""
    global _configured
    import litellm

    if not _configured:
        litellm.suppress_debug_info = True  # no "Give Feedback / Get Help" or "Provider List" prints
        from robocog.agent.policies.providers import register

        register()
        tune(litellm)
        _configured = True
    return litellm


def warm_up_litellm(models: Iterable[str] = ()) -> None:
    """Import LiteLLM and what its first call with tools loads (about 1-2 s), so that no model turn
    pays for it: the offline models, the MCP-tools check LiteLLM makes on every call with tools,
    and, for each of `models`, its route (the OpenAI SDK's resources for `openai/...`). Nothing
    when every model is offline: those never import LiteLLM."""
    models = [m for m in models if not is_offline(m)]
    if not models:
        return
    with contextlib.suppress(Exception):  # a real failure shows on the first real call
        litellm = configured_litellm()
        litellm.completion(model="scripted/refuser", messages=[{"role": "user", "content": "warm up"}])
        import litellm.responses.mcp.chat_completions_handler
        import litellm.responses.mcp.litellm_proxy_mcp_handler
    for model in models:
        with contextlib.suppress(Exception):
            _, provider = _route(model)
            _priced(model)
            _supported(model)
            if provider == "openai":
                import openai

                client = openai.AsyncOpenAI(api_key=PLACEHOLDER_KEY, base_url="http://127.0.0.1:9/v1")
                _ = client.chat.completions  # the SDK imports its resources on first use


# --- credentials ---------------------------------------------------------------------------------


def check_credentials(model: str, api_base: str | None, api_key: str | None = None) -> None:
    """Raise `ModelServiceError` naming the environment variable a cloud model needs and lacks.

    Nothing to check when a key is given, or a server is (`api_base`: a local server needs no key,
    and one that does gets the key given or the placeholder)."""
    if api_key or api_base or is_offline(model):
        return
    verdict, problem = quick_verdict(model)  # most answers, without importing LiteLLM (seconds)
    if verdict == "no_key":
        raise ModelServiceError(problem)
    if verdict != "ask_litellm":  # taken, or not known (then the call itself says so)
        return
    if _route(model)[1] in KEYLESS_ROUTES:
        return
    missing = missing_keys(model)
    if missing:
        raise ModelServiceError(missing_key(model, missing))


def resolve_api_key(spec: ModelSpec) -> str | None:
    """The key of a study's model: `api_key`, else the variable named by `api_key_env`, else None
    (the provider's usual variable, or the placeholder for a server given by `api_base`)."""
    if spec.api_key:
        return spec.api_key
    if spec.api_key_env:
        value = os.environ.get(spec.api_key_env)
        if not value:
            raise ModelServiceError(
                f"model {spec.name!r} takes its key from the environment variable {spec.api_key_env}, which is not set"
            )
        return value
    return None


def _api_key(settings: AgentSettings) -> str | None:
    """The key to send: the one given (`api_key`, or `params`' own), else the placeholder for a
    server given by `api_base` when the provider's variable is not set, else None (LiteLLM reads it)."""
    given = settings.api_key or settings.params.get("api_key")
    if given:
        return str(given)
    # A local server needs no key, but LiteLLM refuses to call without one: send the placeholder,
    # unless the provider's own variable is set (a proxy that takes the usual key).
    keyless = settings.api_base and _route(settings.model)[1] not in KEYLESS_ROUTES
    return PLACEHOLDER_KEY if keyless and missing_keys(settings.model, settings.api_base) else None


# --- what a route takes --------------------------------------------------------------------------


@cache
def _route(model: str) -> tuple[str, str]:
    """(model name, provider) as LiteLLM routes `model`; provider "" when LiteLLM does not know it."""
    try:
        name, provider, *_ = configured_litellm().get_llm_provider(model)
    except Exception:
        return model, ""
    return str(name), str(provider or "")


@cache
def _supported(model: str) -> frozenset[str] | None:
    """The OpenAI parameters the provider of `model` takes (None: unknown, so nothing is dropped)."""
    name, provider = _route(model)
    if not provider or provider in ("scripted", "replay"):
        return None
    try:
        supported = configured_litellm().get_supported_openai_params(model=name, custom_llm_provider=provider)
    except Exception:
        return None
    return frozenset(supported) if supported is not None else None


@cache
def _unsupported(model: str, keys: frozenset[str]) -> frozenset[str]:
    """Which of `keys` are OpenAI parameters that `model`'s provider does not take (what
    `drop_params` leaves out; other keys are provider-specific and passed through)."""
    supported = _supported(model)
    if supported is None:
        return frozenset()
    from litellm.constants import DEFAULT_CHAT_COMPLETION_PARAM_VALUES

    droppable = set(DEFAULT_CHAT_COMPLETION_PARAM_VALUES) - _NEVER_DROPPED
    return frozenset(k for k in keys if k in droppable and k not in supported)


#: LiteLLM's own arguments among the parameters it may drop: never a provider's parameter.
_NEVER_DROPPED = frozenset(
    {
        "model",
        "messages",
        "custom_llm_provider",
        "drop_params",
        "allowed_openai_params",
        "additional_drop_params",
        "max_retries",
        "api_version",
        "extra_headers",
        "metadata",
    }
)

_noticed: set[tuple[str, str]] = set()


def _notice_dropped(model: str, dropped: frozenset[str]) -> None:
    """Say once per process and model which parameters are not sent (one line on stderr)."""
    new = sorted(p for p in dropped if (model, p) not in _noticed)
    if not new:
        return
    _noticed.update((model, p) for p in new)
    names = ", ".join(repr(p) for p in new)
    pronoun = "it is" if len(new) == 1 else "they are"
    print(f"robocog: {model} does not take {names}; {pronoun} not sent", file=sys.stderr)


@cache
def _priced(model: str) -> bool:
    """Whether LiteLLM's local cost map knows `model` (so its cost is a price, not a guess)."""
    name, provider = _route(model)
    cost_map = configured_litellm().model_cost
    for key in (model, f"{provider}/{name}"):
        if cost_map.get(key, {}).get("input_cost_per_token") is not None:
            return True
    info = cost_map.get(name) or {}  # a bare name counts only for its own provider
    return info.get("input_cost_per_token") is not None and info.get("litellm_provider") == provider


def _call_arguments(settings: AgentSettings) -> dict[str, Any]:
    """The keyword arguments of `litellm.acompletion` for `settings`, without what is dropped."""
    kwargs: dict[str, Any] = dict(settings.params)
    if settings.seed is not None:
        kwargs["seed"] = settings.seed
    if settings.temperature is not None:
        kwargs["temperature"] = settings.temperature
    dropped = _unsupported(settings.model, frozenset(kwargs))
    if dropped:
        _notice_dropped(settings.model, dropped)
        for name in dropped:
            del kwargs[name]
    if settings.api_base:
        kwargs["api_base"] = settings.api_base
    key = _api_key(settings)
    if key:
        kwargs["api_key"] = key
    return kwargs


# --- the call ------------------------------------------------------------------------------------


async def complete(
    settings: AgentSettings, messages: list[dict[str, Any]], tools: list[dict[str, Any]], retried: Retries | None = None
) -> Any:
    """One model turn: a LiteLLM call, retried as the failure deserves (each retry and its time added to
    `retried`); raises `ModelServiceError`. An offline model answers in-process; it is never retried."""
    if is_offline(settings.model):
        return await _offline(settings, messages)
    litellm = configured_litellm()
    kwargs = _call_arguments(settings)
    messages, tools, extra = sendable_request(settings.model, messages, tools, settings.api_base)
    kwargs.update(extra)
    priced = _priced(settings.model)
    previous: str | None = None  # the last failure, when a repeat of it would show it deterministic
    for attempt in range(settings.retries + 1):
        started = time.monotonic()
        try:
            with robocog_call(litellm, priced=priced, kwargs=kwargs):
                response = await litellm.acompletion(
                    model=settings.model,
                    messages=messages,
                    tools=tools,
                    timeout=settings.timeout_s,
                    drop_params=True,
                    max_retries=0,
                    **kwargs,
                )
        except Exception as exc:
            failure = classify(exc, settings)
            tries = f" (after {attempt + 1} attempts)" if attempt else ""
            if failure.retry and failure.final_if_repeated and failure.message == previous:
                raise ModelServiceError(f"{failure.message} (the same answer twice: not retried)") from exc
            if not failure.retry or attempt == settings.retries:
                raise ModelServiceError(failure.message + tries) from exc
            previous = failure.message if failure.final_if_repeated else None
            await asyncio.sleep(failure.wait(attempt, settings.backoff_s))
            if retried is not None:
                retried.add(time.monotonic() - started)
            continue
        hidden = compat.hidden_params(response)
        if hidden is not None and not priced:
            hidden["response_cost"] = None  # not in the cost map: unknown, not free
        return response
    raise AssertionError("unreachable")


def sendable_request(
    model: str, messages: list[dict[str, Any]], tools: list[dict[str, Any]], api_base: str | None = None
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], dict[str, Any]]:
    """The messages, the tools and the extra arguments to send `model`, as every server takes them;
    the one place where what local servers need of a request is adapted (LiteLLM translates the
    rest for each provider it knows):

    - `tool_choice: "auto"` whenever tools are offered, where the provider takes it. It is OpenAI's
      own default, but llama.cpp's servers drop the tools from a request without it (llama-cpp-python
      with `chatml-function-calling`): the model then answers in prose and seems merely quiet.
    - An assistant message carries `content: ""`, never `null`: a chat template that reads
      `message.content` (llama.cpp's, vLLM's Jinja templates) fails on null with HTTP 500 on every
      later call. LiteLLM leaves an empty text out for Anthropic, and Ollama takes it.
    - To an OpenAI-compatible server given by `api_base`, a text argument's `maxLength` above
      `LOCAL_MAX_LENGTH` is left out of the tool definitions (the robot server still enforces its
      bound and refuses a longer text in one line): llama.cpp's grammar of a longer one fails, and
      llama-cpp-python's server dies with it. A run's provenance keeps the definitions as offered.
    """
    sent = [{**m, "content": ""} if m.get("role") == "assistant" and m.get("content") is None else m for m in messages]
    supported = _supported(model)
    extra = {"tool_choice": "auto"} if tools and (supported is None or "tool_choice" in supported) else {}
    if api_base and _route(model)[1] in OPENAI_COMPATIBLE:
        tools = [bounded(t) for t in tools]
    return sent, tools, extra


async def _offline(settings: AgentSettings, messages: list[dict[str, Any]]) -> Any:
    """An offline model's turn, after its latency (scripted models' `latency_s`)."""
    params: dict[str, Any] = dict(settings.params)
    if settings.seed is not None:
        params["seed"] = settings.seed
    try:
        response, delay = offline_turn(settings.model, messages, params)
    except OfflineModelError as exc:
        raise ModelServiceError(f"{settings.model} refused the request: {exc}") from None
    if delay:
        await asyncio.sleep(delay)
    return response


# --- pictures ------------------------------------------------------------------------------------

#: What a text-only model reads, in the tool message, in place of each picture a tool returned.
IMAGE_OMITTED = "[image omitted: this model does not take images; run with --vision to send it]"


def image_message(pictures: list[tuple[str, str, str]]) -> dict[str, Any]:
    """The user message that shows a vision model the pictures of a turn's tool results, each given
    as (tool name, MIME type, base64 data). OpenAI-style tool messages carry only text, so the
    pictures follow the turn's tool messages in one user message of `image_url` parts (data URLs);
    LiteLLM turns those into each provider's own image blocks (Anthropic's, Gemini's, Ollama's)."""
    names = sorted({name for name, _, _ in pictures})
    parts: list[dict[str, Any]] = [
        {"type": "text", "text": f"The picture{'s' if len(pictures) > 1 else ''} returned by {', '.join(names)}:"}
    ]
    for _, mime_type, data in pictures:
        parts.append({"type": "image_url", "image_url": {"url": f"data:{mime_type};base64,{data}"}})
    return {"role": "user", "content": parts}


# --- what a response carries ---------------------------------------------------------------------


def assistant_message(response: Any) -> dict[str, Any]:
    """The response's first choice as an OpenAI-style assistant message (a text turn's content is
    the text; a tool-call turn's empty content is None)."""
    msg = response.choices[0].message
    out: dict[str, Any] = {"role": "assistant", "content": msg.content or None}
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


def finish_reason(response: Any) -> str | None:
    """Why the model stopped writing its turn, as the provider said: "stop", "tool_calls", "length"
    (cut at the token limit), ...; None when it said nothing."""
    reason = getattr(response.choices[0], "finish_reason", None)
    return str(reason) if reason else None


def usage(response: Any) -> tuple[int, int, float | None]:
    """(prompt tokens, completion tokens, cost) of a response, as the provider reported them; the
    cost is None unless the model is priced in LiteLLM's local cost map."""
    reported = getattr(response, "usage", None)
    tokens_in = int(getattr(reported, "prompt_tokens", 0) or 0)
    tokens_out = int(getattr(reported, "completion_tokens", 0) or 0)
    cost = None
    hidden = compat.hidden_params(response) or {}
    if hidden.get("response_cost") is not None:
        cost = float(hidden["response_cost"])
    return tokens_in, tokens_out, cost
