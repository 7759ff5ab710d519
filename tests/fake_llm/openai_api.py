"""The OpenAI chat completions format (``POST /v1/chat/completions``): a turn as a response, a
request's messages as neutral ones (already neutral: content blocks flattened to text)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from tests.fake_llm.format_helpers import args_json, text_of

if TYPE_CHECKING:
    from tests.fake_llm.replies import Turn


def response(
    turn: Turn, model: str, call_ids: list[str], ids: Iterator[str], now: int, usage: tuple[int, int]
) -> dict[str, Any]:
    """`turn` as a chat completion, its tool calls named by `call_ids`, its own id the next of `ids`."""
    prompt, completion = usage
    message: dict[str, Any] = {"role": "assistant", "content": turn.text}
    if turn.tool_calls:
        message["tool_calls"] = [
            {"id": i, "type": "function", "function": {"name": name, "arguments": args_json(args)}}
            for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True)
        ]
    return {
        "id": f"chatcmpl-{next(ids)}",
        "object": "chat.completion",
        "created": now,
        "model": model,
        "choices": [
            {
                "index": 0,
                "message": message,
                "finish_reason": turn.finish_reason or ("tool_calls" if turn.tool_calls else "stop"),
            }
        ],
        "usage": {"prompt_tokens": prompt, "completion_tokens": completion, "total_tokens": prompt + completion},
    }


def neutral(body: dict[str, Any]) -> list[dict[str, Any]]:
    """The request's messages as they are, content blocks flattened to text."""
    out: list[dict[str, Any]] = []
    for m in list(body.get("messages") or []):
        msg = dict(m)
        if isinstance(msg.get("content"), list):
            msg["content"] = text_of(msg["content"])
        out.append(msg)
    return out
