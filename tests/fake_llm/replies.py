"""What a script answers (a neutral `Turn`, a `Fail`, a `Raw` body) and what the server received (`Request`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

from tests.fake_llm.formats import neutral_messages

Provider = Literal["openai", "anthropic", "ollama"]


@dataclass
class Turn:
    """One assistant turn, provider-neutral.

    ``tool_calls``: ``(name, arguments)`` pairs; arguments as a dict, or as a raw string sent verbatim
    (e.g. ``'{"object": "apple"'`` for malformed JSON, or a JSON string of the JSON object for
    double-encoded arguments). ``usage``: ``(prompt_tokens, completion_tokens)``;
    by default an estimate of 4 characters a token over the request and the turn. ``delay``: seconds
    to wait before answering. ``ids``: tool call ids to use instead of generated ones.
    """

    text: str | None = None
    tool_calls: list[tuple[str, dict[str, Any] | str]] = field(default_factory=list)
    usage: tuple[int, int] | None = None
    delay: float = 0.0
    ids: list[str] | None = None
    finish_reason: str | None = None  # OpenAI's: "length" for a turn cut at max_tokens (default: as the turn is)


@dataclass
class Fail:
    """An HTTP error in the provider's error format, e.g. ``Fail(429, headers={"Retry-After": "7"})``."""

    status: int
    message: str = ""
    headers: dict[str, str] = field(default_factory=dict)
    delay: float = 0.0


@dataclass
class Raw:
    """A response sent exactly as given (``body``: a dict is sent as JSON, bytes/str verbatim)."""

    body: dict[str, Any] | str | bytes
    status: int = 200
    headers: dict[str, str] = field(default_factory=dict)
    delay: float = 0.0


Reply = Turn | Fail | Raw | dict
Script = Callable[["Request"], Reply] | Iterable[Reply]


@dataclass
class Request:
    """A request the server received (headers with lower-case names)."""

    provider: Provider | None
    method: str
    path: str
    headers: dict[str, str]
    body: Any
    received: float = 0.0  # time.perf_counter() when the body had been read
    server_s: float = 0.0  # the server's own time on it (request line in -> response out), scripted delay excluded
    delay_s: float = 0.0  # the scripted delay it was answered after
    status: int = 0

    @property
    def messages(self) -> list[dict[str, Any]]:
        """The messages in the provider's own format."""
        return list((self.body or {}).get("messages") or []) if isinstance(self.body, dict) else []

    def neutral(self) -> list[dict[str, Any]]:
        """The conversation as OpenAI-style messages (system/user/assistant with tool_calls/tool)."""
        return neutral_messages(self.provider or "openai", self.body if isinstance(self.body, dict) else {})

    def images(self) -> list[tuple[str, str]]:
        """Every picture the request carries, as (role of its message, base64 data), in the provider's
        own format: OpenAI `image_url` parts with data URLs, Anthropic `image` blocks with a base64
        source (also inside tool results), Ollama's `images` lists."""
        found: list[tuple[str, str]] = []

        def walk(role: str, content: Any) -> None:
            for part in content if isinstance(content, list) else []:
                if not isinstance(part, dict):
                    continue
                if part.get("type") == "image_url":
                    url = part["image_url"]["url"] if isinstance(part.get("image_url"), dict) else part["image_url"]
                    found.append((role, str(url).split(",", 1)[-1]))
                elif part.get("type") == "image" and isinstance(part.get("source"), dict):
                    found.append((role, str(part["source"].get("data", ""))))
                elif part.get("type") == "tool_result":
                    walk(role, part.get("content"))

        for message in self.messages:
            role = str(message.get("role", ""))
            walk(role, message.get("content"))
            found.extend((role, str(image)) for image in message.get("images") or [])
        return found

    @property
    def api_key(self) -> str | None:
        """The credential the client sent (Bearer token or x-api-key), if any."""
        auth = self.headers.get("authorization")
        if auth:
            return auth.split(" ", 1)[1] if auth.lower().startswith("bearer ") else auth
        return self.headers.get("x-api-key")
