"""The Ollama chat format (``POST /api/chat``, and ``POST /api/show`` about the model): a turn as a
response, a request's conversation as neutral OpenAI-style messages."""

from __future__ import annotations

import itertools
import time
from collections import deque
from typing import TYPE_CHECKING, Any

from tests.fake_llm.format_helpers import args_json, text_of

if TYPE_CHECKING:
    from tests.fake_llm.replies import Turn

#: What ``POST /api/show`` answers: a tool-capable model with a 32k context.
OLLAMA_SHOW: dict[str, Any] = {
    "template": "{{- if .Tools }}{{ .Tools }}{{ end }}{{ .Prompt }}",
    "details": {"family": "fake", "parameter_size": "1B", "quantization_level": "Q4_K_M"},
    "model_info": {"general.architecture": "fake", "fake.context_length": 32768},
    "capabilities": ["completion", "tools"],
}


def response(
    turn: Turn, model: str, call_ids: list[str], usage: tuple[int, int], *, ollama_ids: bool
) -> dict[str, Any]:
    """`turn` as a chat response. Arguments are objects; ids are sent only when the server is told to
    (`ollama_ids`) or the turn names its own."""
    prompt, completion = usage
    message: dict[str, Any] = {"role": "assistant", "content": turn.text or ""}
    if turn.tool_calls:
        message["tool_calls"] = [
            {"function": {"name": name, "arguments": args}, **({"id": i} if turn.ids or ollama_ids else {})}
            for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True)
        ]
    return {
        "model": model,
        "created_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "message": message,
        "done": True,
        "done_reason": "stop",
        "prompt_eval_count": prompt,
        "eval_count": completion,
    }


def neutral(body: dict[str, Any]) -> list[dict[str, Any]]:
    """LiteLLM drops the ids of the assistant's tool calls but keeps ``tool_call_id`` on the tool
    messages, so each call takes the id of the tool message that answers it (by position)."""
    messages = list(body.get("messages") or [])
    out: list[dict[str, Any]] = []
    counter = itertools.count(1)
    for n, m in enumerate(messages):
        msg: dict[str, Any] = {"role": m.get("role"), "content": text_of(m.get("content"))}
        if m.get("role") == "assistant":
            calls = m.get("tool_calls") or []
            if not msg["content"]:
                msg["content"] = None
            if calls:
                answers = [
                    x.get("tool_call_id")
                    for x in itertools.takewhile(lambda x: x.get("role") == "tool", messages[n + 1 :])
                ]
                msg["tool_calls"] = []
                for i, c in enumerate(calls):
                    fn = c.get("function") or {}
                    call_id = c.get("id") or (answers[i] if i < len(answers) and answers[i] else None)
                    msg["tool_calls"].append(
                        {
                            "id": call_id or f"ollama_call_{next(counter)}",
                            "type": "function",
                            "function": {"name": fn.get("name"), "arguments": args_json(fn.get("arguments", {}))},
                        }
                    )
        elif m.get("role") == "tool":
            msg["tool_call_id"] = m.get("tool_call_id")
        out.append(msg)
    # tool messages without an id: pair them by position with the calls before them
    pending: deque[str] = deque()
    for msg in out:
        if msg["role"] == "assistant":
            pending = deque(c["id"] for c in msg.get("tool_calls") or [])
        elif msg["role"] == "tool":
            expected = pending.popleft() if pending else None
            if not msg.get("tool_call_id"):
                msg["tool_call_id"] = expected
    return out
