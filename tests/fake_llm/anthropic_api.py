"""The Anthropic messages format (``POST /v1/messages``): a turn as a response, a request's
conversation as neutral OpenAI-style messages."""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from tests.fake_llm.format_helpers import args_json, text_of

if TYPE_CHECKING:
    from tests.fake_llm.replies import Turn


def response(turn: Turn, model: str, call_ids: list[str], ids: Iterator[str], usage: tuple[int, int]) -> dict[str, Any]:
    """`turn` as a message with text and tool_use blocks, its own id the next of `ids`."""
    prompt, completion = usage
    content: list[dict[str, Any]] = []
    if turn.text:
        content.append({"type": "text", "text": turn.text})
    for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True):
        # The real API always sends an object; a raw string is passed through for malformed-input tests.
        content.append({"type": "tool_use", "id": i, "name": name, "input": args})
    return {
        "id": f"msg_{next(ids)}",
        "type": "message",
        "role": "assistant",
        "model": model,
        "content": content,
        "stop_reason": "tool_use" if turn.tool_calls else "end_turn",
        "stop_sequence": None,
        "usage": {"input_tokens": prompt, "output_tokens": completion},
    }


def neutral(body: dict[str, Any]) -> list[dict[str, Any]]:
    """The top-level ``system`` becomes a system message; ``tool_use`` blocks become ``tool_calls``
    (arguments re-serialised as JSON); ``tool_result`` blocks become ``tool`` messages."""
    messages = list(body.get("messages") or [])
    out: list[dict[str, Any]] = []
    if body.get("system"):
        out.append({"role": "system", "content": text_of(body["system"])})
    for m in messages:
        content = m.get("content")
        blocks = content if isinstance(content, list) else [{"type": "text", "text": content or ""}]
        if m.get("role") == "assistant":
            text = "".join(b.get("text", "") for b in blocks if b.get("type") == "text")
            calls = [
                {
                    "id": b.get("id"),
                    "type": "function",
                    "function": {"name": b.get("name"), "arguments": args_json(b.get("input", {}))},
                }
                for b in blocks
                if b.get("type") == "tool_use"
            ]
            msg: dict[str, Any] = {"role": "assistant", "content": text or None}
            if calls:
                msg["tool_calls"] = calls
            out.append(msg)
            continue
        texts = []
        for b in blocks:
            if b.get("type") == "tool_result":
                out.append({"role": "tool", "tool_call_id": b.get("tool_use_id"), "content": text_of(b.get("content"))})
            elif b.get("type") == "text":
                texts.append(b.get("text", ""))
        if texts:
            out.append({"role": m.get("role", "user"), "content": "".join(texts)})
    return out
