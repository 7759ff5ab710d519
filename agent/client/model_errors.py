"""What a failed model call means: the one-line message with the provider's own words, whether a
retry can help, and how long to wait (the provider's `Retry-After`, else backoff with jitter).

`robocog.agent.client.model.complete` is the only caller; this module imports LiteLLM only when it classifies.
"""

from __future__ import annotations

import ast
import contextlib
import json
import random
import re
import time
from dataclasses import dataclass
from email.utils import parsedate_to_datetime
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from robocog.agent.client.settings import AgentSettings


@dataclass
class Retries:
    """What one turn lost before its answer: the failed attempts `complete()` retried, and the seconds
    they and the waits after them took (the turn's latency includes them)."""

    count: int = 0
    seconds: float = 0.0

    def add(self, seconds: float) -> None:
        self.count += 1
        self.seconds += seconds


#: The longest a rate limit's `Retry-After` is honoured for, in seconds.
MAX_RETRY_AFTER_S = 60.0
#: The longest backoff between two attempts when the provider says nothing, in seconds.
MAX_BACKOFF_S = 30.0
#: HTTP statuses that no retry can fix.
FINAL_STATUSES = frozenset({400, 401, 403, 404, 405, 413, 422})
#: Retried statuses that say "later" by their very meaning (a rate limit, a gateway, an overload): the
#: same body again is expected of them. Any other status whose body repeats is deterministic (a chat
#: template that fails on the history answers 500 with the same words every time): not retried again.
TRANSIENT_STATUSES = frozenset({429, 502, 503, 504, 529})

_STATUS_KINDS = {
    400: "bad request",
    401: "authentication",
    403: "permission denied",
    404: "not found",
    408: "timeout",
    409: "conflict",
    413: "request too large",
    422: "unprocessable request",
    429: "rate limit",
    500: "server error",
    502: "bad gateway",
    503: "unavailable",
    504: "gateway timeout",
    529: "overloaded",
}


@dataclass(frozen=True)
class Failure:
    """What a failed call means: the one-line message, whether to try again, and how long to wait."""

    message: str
    retry: bool
    retry_after: float | None = None  # what the provider asked for, in seconds
    #: An answer of the server that, said twice in the same words, is deterministic: not retried again.
    final_if_repeated: bool = False

    def wait(self, attempt: int, backoff_s: float) -> float:
        """Seconds to wait before attempt `attempt + 1`: the provider's Retry-After (capped), else
        exponential backoff with jitter."""
        if self.retry_after is not None:
            return min(MAX_RETRY_AFTER_S, max(0.0, self.retry_after))
        return min(MAX_BACKOFF_S, backoff_s * 2.0**attempt) * (0.5 + random.random())


def classify(exc: BaseException, settings: AgentSettings) -> Failure:
    """Turn LiteLLM's exception into a `Failure` (one line, with the provider's own message)."""
    import litellm

    model = settings.model
    text = provider_message(exc)
    status = getattr(exc, "status_code", None)
    status = status if isinstance(status, int) else None
    if isinstance(exc, litellm.Timeout):
        return Failure(f"{model} did not answer within {settings.timeout_s:g} s", retry=True)
    if _missing_credentials(text):  # raised before any request (OpenAI's comes as a server error)
        missing = missing_keys(model)
        hint = f"set {', '.join(missing)} or give --api-key" if missing else "give --api-key"
        return Failure(f"{model} has no API key: {hint}", retry=False)
    if isinstance(exc, litellm.APIConnectionError) or _cannot_connect(text):
        where = settings.api_base or "its provider"
        if _client_side(exc):  # e.g. a history LiteLLM cannot translate: no retry will help
            return Failure(f"{model}: the request could not be built: {text}", retry=False)
        return Failure(f"{model} could not be reached at {where}: {text}", retry=True)
    if isinstance(exc, litellm.UnsupportedParamsError):
        return Failure(f"{model} answered 400 (bad request): {text}", retry=False)
    if status is not None and status >= 400:
        kind = _STATUS_KINDS.get(status, "error")
        message = f"{model} answered {status} ({kind}): {text}"
        if status == 429:
            return Failure(message, retry=True, retry_after=retry_after(exc))
        retry = status not in FINAL_STATUSES and (status >= 500 or status == 408)
        return Failure(message, retry=retry, final_if_repeated=status not in TRANSIENT_STATUSES)
    return Failure(f"{model} failed ({type(exc).__name__}): {text}", retry=False)


def missing_keys(model: str, api_base: str | None = None) -> list[str]:
    """The environment variables LiteLLM says `model` needs and lacks (none for unknown providers)."""
    import litellm

    try:
        check = litellm.validate_environment(model=model, api_base=api_base)
    except Exception:  # an unknown provider: let the call itself say what is wrong
        return []
    return list(check.get("missing_keys") or [])


def _missing_credentials(text: str) -> bool:
    return any(
        marker in text
        for marker in ("Missing credentials", "api_key client option must be set", "Missing Anthropic API Key")
    )


def _cannot_connect(text: str) -> bool:
    return text.startswith("Connection error") or text.startswith("Cannot connect to host")


def _client_side(exc: BaseException) -> bool:
    """Whether the exception was caused by our own data (a JSON or type error), not the network."""
    seen = 0
    cause: BaseException | None = exc.__cause__ or exc.__context__
    while cause is not None and seen < 10:
        if isinstance(cause, ValueError | TypeError | KeyError) and not isinstance(cause, OSError):
            return True
        cause, seen = cause.__cause__ or cause.__context__, seen + 1
    return "Expecting " in str(exc) and "delimiter" in str(exc)


_PREFIX = re.compile(r"^(?:litellm\.)?[A-Za-z_]+(?:Error|Exception)\s*(?::|-)\s*")
_HANDLE_WITH = re.compile(r"\.?\s*Handle with `litellm\.\w+`\.?\s*$")
_ERROR_CODE = re.compile(r"^Error code: \d+\s*-\s*")


def provider_message(exc: BaseException, limit: int = 300) -> str:
    """The provider's own message in LiteLLM's exception, on one line: LiteLLM's class-name
    prefixes and hints stripped, a JSON error body reduced to its message."""
    text = str(getattr(exc, "message", None) or exc or type(exc).__name__)
    for _ in range(5):
        stripped = _ERROR_CODE.sub("", _PREFIX.sub("", text.strip(), count=1))
        if stripped == text:
            break
        text = stripped
    text = text.split("Traceback (most recent call last)", 1)[0]  # LiteLLM appends one to some errors
    text = _HANDLE_WITH.sub("", text.strip())
    start = text.find("{")
    if start != -1:
        body = _parse_body(text[start:])
        found = _error_text(body) if body is not None else None
        if found:
            text = (text[:start].rstrip(" -:") + ": " if text[:start].strip(" -:") else "") + found
    text = re.sub(r"\s*ssl:<[^>]*>", "", text)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _parse_body(text: str) -> Any:
    for parse in (json.loads, ast.literal_eval):
        try:
            return parse(text)
        except Exception:
            continue
    return None


def _error_text(body: Any) -> str | None:
    """The message of a provider's error body: {"error": {"message": ...}}, {"error": "..."}, ..."""
    if isinstance(body, str):
        return body
    if not isinstance(body, dict):
        return None
    for key in ("error", "message", "detail", "msg"):
        value = body.get(key)
        if isinstance(value, str) and value:
            return value
        if isinstance(value, dict):
            found = _error_text(value)
            if found:
                return found
    return None


def retry_after(exc: BaseException) -> float | None:
    """The seconds a rate-limited provider asked to wait (`Retry-After`, seconds or an HTTP date;
    or `retry-after-ms`), from the provider's headers LiteLLM keeps on the exception."""
    import httpx

    raw = getattr(exc, "litellm_response_headers", None)
    if raw is None:
        response = getattr(exc, "response", None)
        raw = getattr(response, "headers", None)
    try:
        headers = httpx.Headers(raw or {})
    except Exception:
        return None
    if headers.get("retry-after-ms"):
        with contextlib.suppress(ValueError):
            return float(headers["retry-after-ms"]) / 1000.0
    value = headers.get("retry-after")
    if not value:
        return None
    try:
        return float(value)
    except ValueError:
        pass
    try:
        return parsedate_to_datetime(value).timestamp() - time.time()
    except (TypeError, ValueError):
        return None
