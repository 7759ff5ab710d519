"""The three provider APIs' formats, dispatched: a `Turn` rendered as a response body, a `Fail` as an
error body, a request's conversation turned back into neutral OpenAI-style messages. Each provider's
own format is in `openai_api`, `anthropic_api` and `ollama_api`."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from tests.fake_llm import anthropic_api, ollama_api, openai_api
from tests.fake_llm.format_helpers import counter, estimate

if TYPE_CHECKING:
    from tests.fake_llm.replies import Fail, Provider, Turn


def render(
    provider: Provider,
    turn: Turn,
    request_body: dict[str, Any] | None = None,
    ids: Iterator[str] | None = None,
    *,
    ollama_ids: bool = False,
) -> dict[str, Any]:
    """`turn` as a successful response body of `provider`, answering `request_body`.

    ``ids`` numbers the tool calls and the response (``call_0001``, ``toolu_0001``...; a fresh count by
    default). Ollama sends no tool call ids unless ``ollama_ids`` (or the turn's own ``ids``).
    """
    request_body = request_body or {}
    ids = ids if ids is not None else counter()
    model = str(request_body.get("model", "fake"))
    prompt, completion = turn.usage or (
        estimate(request_body.get("messages")) + estimate(request_body.get("tools") or []),
        estimate([turn.text, turn.tool_calls]),
    )
    prefix = "toolu_" if provider == "anthropic" else "call_"
    call_ids = list(turn.ids or [])
    call_ids += [prefix + next(ids) for _ in range(len(turn.tool_calls) - len(call_ids))]
    now = int(time.time())
    if provider == "openai":
        return openai_api.response(turn, model, call_ids, ids, now, (prompt, completion))
    if provider == "anthropic":
        return anthropic_api.response(turn, model, call_ids, ids, (prompt, completion))
    return ollama_api.response(turn, model, call_ids, (prompt, completion), ollama_ids=ollama_ids)


_ERROR_TYPES = {
    400: "invalid_request_error",
    401: "authentication_error",
    403: "permission_error",
    404: "not_found_error",
    429: "rate_limit_error",
    500: "api_error",
    529: "overloaded_error",
}


def render_error(provider: Provider | None, fail: Fail) -> dict[str, Any]:
    """`fail` as an error body of `provider`."""
    kind = _ERROR_TYPES.get(fail.status, "api_error")
    message = fail.message or f"fake_llm: scripted HTTP {fail.status} ({kind})"
    if provider == "anthropic":
        return {"type": "error", "error": {"type": kind, "message": message}}
    if provider == "ollama":
        return {"error": message}
    return {"error": {"message": message, "type": kind, "param": None, "code": str(fail.status)}}


def neutral_messages(provider: Provider, body: dict[str, Any]) -> list[dict[str, Any]]:
    """A provider request's conversation as OpenAI-style message dicts, as the planner reads them
    (the providers' own rules in `anthropic_api.neutral` and `ollama_api.neutral`)."""
    if provider == "anthropic":
        return anthropic_api.neutral(body)
    if provider == "ollama":
        return ollama_api.neutral(body)
    return openai_api.neutral(body)
