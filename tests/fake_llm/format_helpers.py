"""What the providers' formats share: ids, token estimates, arguments as JSON, content as text."""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from typing import Any


def counter() -> Iterator[str]:
    """Numbers for ids: "0001", "0002", ..."""
    return (f"{n:04d}" for n in itertools.count(1))


def estimate(value: Any) -> int:
    """Tokens, estimated at 4 characters a token."""
    return max(1, len(json.dumps(value, default=str)) // 4)


def args_json(arguments: dict[str, Any] | str) -> str:
    """Tool call arguments as a JSON string (a raw string is kept as it is)."""
    return arguments if isinstance(arguments, str) else json.dumps(arguments)


def text_of(content: Any) -> str:
    """A message's content as text (content blocks joined)."""
    if content is None:
        return ""
    if isinstance(content, str):
        return content
    if isinstance(content, list):
        return "".join(b.get("text", "") if isinstance(b, dict) else str(b) for b in content)
    return str(content)
