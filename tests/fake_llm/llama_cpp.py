"""A llama.cpp server as it really answers (llama-cpp-python 0.3.36's OpenAI-compatible server with
`--chat_format chatml-function-calling`, as measured with a real 1.5B model), laid over a script:

- **tools dropped without `tool_choice`**: a request with `tools` and no `tool_choice` reaches the model
  without its tools, so a model that meant to call one answers in prose instead (each call the script
  made becomes a line such as ``Move_to: {"location": "Kitchen Table"}``, as the real model wrote);
- **a 500 on `content: null`**: an assistant message whose content is null (or missing) breaks the
  chat template, every time, with the same body: ``'dict object' has no attribute 'content'``;
- **no grammar for a long `maxLength`**: a tool whose text argument allows 2,000 characters or more
  cannot be made a grammar; the real server dies then (every later request is refused), which this
  one stands for with a 500 naming the grammar.

The model's own slips (double-encoded arguments, tool calls written as text, a turn cut at
`max_tokens`) are the script's to write: see `Turn`.

    fake.script = llama_cpp(planner_script())
"""

from __future__ import annotations

import json
from collections.abc import Callable

from tests.fake_llm.replies import Fail, Reply, Request, Turn

#: What the server's Jinja chat template answers for an assistant message with `content: null`.
TEMPLATE_ERROR = "'dict object' has no attribute 'content'"
#: What llama.cpp says of a grammar whose rule repeats 2,000 times or more (a `maxLength` that long).
GRAMMAR_ERROR = "failed to parse grammar: number of rules that are going to be repeated exceeds sane defaults"
GRAMMAR_LIMIT = 2000


def llama_cpp(script: Callable[[Request], Reply]) -> Callable[[Request], Reply]:
    """`script` behind a llama.cpp server's edges (see the module's docstring)."""

    def answer(request: Request) -> Reply:
        body = request.body if isinstance(request.body, dict) else {}
        for message in body.get("messages") or []:
            if message.get("role") == "assistant" and message.get("content") is None:
                return Fail(500, TEMPLATE_ERROR)
        if "tool_choice" in body and _longest(body.get("tools")) >= GRAMMAR_LIMIT:
            return Fail(500, GRAMMAR_ERROR)
        reply = script(request)
        if body.get("tools") and "tool_choice" not in body and isinstance(reply, Turn) and reply.tool_calls:
            return Turn(text=prose(reply), usage=reply.usage)
        return reply

    return answer


def prose(turn: Turn) -> str:
    """What a model without its tools writes for the calls it meant (one line each, as the real one did)."""
    lines = [turn.text] if turn.text else []
    for name, arguments in turn.tool_calls:
        shown = arguments if isinstance(arguments, str) else json.dumps(arguments)
        lines.append(f"{name.capitalize()}: {shown}")
    return "\n".join(lines)


def _longest(value: object) -> int:
    """The largest `maxLength` anywhere in `value` (0: none)."""
    if isinstance(value, dict):
        own = value.get("maxLength")
        return max([own if isinstance(own, int) else 0, *(_longest(v) for v in value.values())])
    if isinstance(value, list):
        return max([0, *(_longest(v) for v in value)])
    return 0
