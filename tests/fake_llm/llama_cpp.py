"""A llama.cpp server as it really answers (llama-cpp-python 0.3.36's OpenAI-compatible server with
`--chat_format chatml-function-calling`, as measured with a real 1.5B model), laid over a script:

- **tools dropped without `tool_choice`**: a request with `tools` and no `tool_choice` reaches the model
  without its tools, so a model that meant to call one answers in prose instead (each call the script
  made becomes a line such as ``Move_to: {"location": "Kitchen Table"}``, as the real model wrote);
- **a 500 on `content: null`**: an assistant message whose content is null (or missing) breaks the
  chat template, every time, with the same body: ``'dict object' has no attribute 'content'``.

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


def llama_cpp(script: Callable[[Request], Reply]) -> Callable[[Request], Reply]:
    """`script` behind a llama.cpp server's edges (see the module's docstring)."""

    def answer(request: Request) -> Reply:
        body = request.body if isinstance(request.body, dict) else {}
        for message in body.get("messages") or []:
            if message.get("role") == "assistant" and message.get("content") is None:
                return Fail(500, TEMPLATE_ERROR)
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
