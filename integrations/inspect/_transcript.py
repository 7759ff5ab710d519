"""Reading an Inspect episode's transcript: a tool result's text, the status end_task claimed, and
whether end_task ended the episode (`robocog.inspect._tasks` and `_suite` read them)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from inspect_ai.model import ChatMessage, ChatMessageAssistant, ChatMessageTool, ContentText


def text_of(result: Any) -> str:
    """A tool result (string or content list) as text."""
    if isinstance(result, str):
        return result
    if isinstance(result, list):
        return "\n".join(item.text for item in result if isinstance(item, ContentText))
    return str(result)


def believed_status(messages: Sequence[ChatMessage]) -> bool | None:
    """end_task's status from the first end_task call that ended the episode (its result no error):
    True for 'success', False for 'failure', None when the episode was never ended."""
    results = {m.tool_call_id: m for m in messages if isinstance(m, ChatMessageTool)}
    for message in messages:
        if not isinstance(message, ChatMessageAssistant):
            continue
        for call in message.tool_calls or []:
            result = results.get(call.id)
            if call.function == "end_task" and result is not None and result.error is None:
                return call.arguments.get("status") == "success"
    return None


def ended(messages: Sequence[ChatMessage]) -> bool:
    """Whether an end_task call ended the episode."""
    return any(m.function == "end_task" and m.error is None for m in messages if isinstance(m, ChatMessageTool))
