"""A model's slips in writing its tool calls, read where its intent is clear and counted, never hidden.

- Arguments double-encoded (`"{\\"object\\": \\"mug\\"}"`, a JSON string holding the JSON object) are
  decoded and run as the model meant: the call is recorded with `slip: "double_encoded"`, and the
  conversation keeps the arguments as the object, so the model's view says nothing misleading.
- A tool call written as text in a turn's content (the server did not parse it into `tool_calls`:
  Hermes' `<tool_call>{...}</tool_call>`, `<function name="move_to" .../>` or `<function=move_to>`,
  `functions.move_to:`, a JSON object naming an offered tool) is not run: nothing says which of a
  turn's texts the model meant to act on. It is counted on the turn (`text_tool_calls`) and by the
  taxonomy as a parse error, and `robocog run` says in one line that the server may not parse tool calls.
- A turn cut at the token limit (`finish_reason: "length"`) is counted apart.

The taxonomy (`robocog.agent.analysis.taxonomy`) and a results row's `slips` read them from the trace.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable
from typing import Any, Literal

Slip = Literal["double_encoded"]


def decode_arguments(raw: str) -> tuple[dict[str, Any] | None, Slip | None, str | None]:
    """A tool call's raw arguments as (the object, the slip if any, the problem if not an object).

    Empty arguments are `{}`; a JSON string whose text is itself a JSON object is that object, with
    the slip `double_encoded`; anything else that is not a JSON object is a problem for the model."""
    try:
        parsed = json.loads(raw) if raw.strip() else {}
    except json.JSONDecodeError as exc:
        return None, None, f"are not a valid JSON object ({exc})"
    if isinstance(parsed, str):
        try:
            inner = json.loads(parsed)
        except json.JSONDecodeError:
            inner = None
        if isinstance(inner, dict):
            return inner, "double_encoded", None
    if isinstance(parsed, dict):
        return parsed, None, None
    return None, None, f"must be a JSON object, not {type(parsed).__name__}"


_HERMES = re.compile(r"<tool_call>\s*(.*?)\s*(?:</tool_call>|$)", re.S)
_FUNCTION_TAG = re.compile(r"<function(?:\s+name\s*=\s*[\"']?|=)([A-Za-z_][\w.-]*)")
_FUNCTIONS_DOT = re.compile(r"\bfunctions\.([A-Za-z_]\w*)")
_NAME_KEYS = ("name", "function", "tool", "tool_name")


def text_tool_calls(content: str | None, tools: Iterable[str]) -> int:
    """How many tool calls `content` writes as text, of the tools offered (`tools`); 0 for prose."""
    if not content:
        return 0
    names = set(tools)
    found = len(_HERMES.findall(content))
    rest = _HERMES.sub(" ", content)
    found += sum(1 for name in _FUNCTION_TAG.findall(rest) if name in names)
    rest = _FUNCTION_TAG.sub(" ", rest)
    found += sum(1 for name in _FUNCTIONS_DOT.findall(rest) if name in names)
    rest = _FUNCTIONS_DOT.sub(" ", rest)
    return found + sum(1 for obj in _json_objects(rest) if _names_a_tool(obj, names))


def text_calls_notice(model: str, count: int) -> str:
    """The one line that says a model wrote tool calls as text (`robocog run`, `robocog eval`)."""
    calls = "1 tool call" if count == 1 else f"{count} tool calls"
    return (
        f"{model} wrote {calls} as text, not run; the server may not parse tool calls "
        "(docs/models.md, 'When a local model writes its tool calls as text')"
    )


def _names_a_tool(obj: Any, names: set[str]) -> bool:
    if not isinstance(obj, dict):
        return False
    for key in _NAME_KEYS:
        value = obj.get(key)
        if isinstance(value, str) and value in names:
            return True
        if isinstance(value, dict) and _names_a_tool(value, names):  # {"function": {"name": ...}}
            return True
    return False


def _json_objects(text: str) -> list[Any]:
    """The JSON values that start at each top-level `{` or `[` of `text` and parse."""
    decoder = json.JSONDecoder()
    out: list[Any] = []
    i = 0
    while i < len(text):
        if text[i] in "{[":
            try:
                value, end = decoder.raw_decode(text, i)
            except json.JSONDecodeError:
                i += 1
                continue
            out.extend(value if isinstance(value, list) else [value])
            i = end
        else:
            i += 1
    return out
