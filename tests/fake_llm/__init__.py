"""A scripted model service on loopback, speaking three provider APIs over real HTTP.

One server answers all three routes LiteLLM knows, non-streaming JSON only:

- OpenAI chat completions  ``POST /v1/chat/completions``  (LiteLLM: ``openai/NAME``, ``api_base=srv.openai_base``)
- Anthropic messages       ``POST /v1/messages``          (LiteLLM: ``anthropic/NAME``, ``api_base=srv.anthropic_base``)
- Ollama chat              ``POST /api/chat``             (LiteLLM: ``ollama_chat/NAME``, ``api_base=srv.ollama_base``)

What it answers comes from a *script*: a callable ``(Request) -> reply`` or a sequence of replies
served in order. A reply is a neutral `Turn` (text and/or tool calls, rendered in the provider's own
format), a `Fail` (an HTTP error in the provider's error format, e.g. 429 with ``Retry-After``), a
`Raw` body, or a plain dict (sent as is with 200). Turns and fails may carry a ``delay`` (seconds
before answering: longer than the client's timeout makes a timeout). Every request is recorded
(`FakeLLM.requests`: path, headers, JSON body, and the server's own time on it).

`planner_script()` makes the repo's scripted planner answer through HTTP: each request's messages
are turned back into neutral OpenAI-style messages (`neutral_messages`) and `decide()` picks the
next call, so a full episode runs through a real provider route.

    with FakeLLM([Turn(tool_calls=[("look_around", {})]), Turn(text="done")]) as srv:
        litellm.completion(model="openai/fake", api_base=srv.openai_base, api_key="sk-no-key-required", ...)
        srv.requests[0].body

As a pytest fixture: ``from tests.fake_llm.pytest_fixture import fake_llm_fixture  # noqa: F401``, then take
``fake_llm`` (a started server; script it with ``fake_llm.script = ...`` or ``fake_llm.reply(...)``).
From a shell, for trying the CLI by hand: ``python -m tests.fake_llm --port 8765`` serves the
planner on all routes.

Loopback only, no dependency beyond the standard library (the planner is imported on demand).

Modules: `replies` (what a script returns, what the server received), `formats` (dispatch over the
providers) with `openai_api`, `anthropic_api` and `ollama_api` (each provider's own format),
`scripts` (the planner), `llama_cpp` (a llama.cpp server's edges over any script: tools dropped
without `tool_choice`, a 500 on `content: null`), `server` (`FakeLLM`), `pytest_fixture`, `__main__` (the command line).
"""

from tests.fake_llm.formats import neutral_messages, render, render_error
from tests.fake_llm.llama_cpp import TEMPLATE_ERROR, llama_cpp
from tests.fake_llm.replies import Fail, Provider, Raw, Reply, Request, Script, Turn
from tests.fake_llm.scripts import planner_script
from tests.fake_llm.server import PATHS, PLACEHOLDER_KEY, FakeLLM

__all__ = [
    "PATHS",
    "PLACEHOLDER_KEY",
    "TEMPLATE_ERROR",
    "Fail",
    "FakeLLM",
    "Provider",
    "Raw",
    "Reply",
    "Request",
    "Script",
    "Turn",
    "llama_cpp",
    "neutral_messages",
    "planner_script",
    "render",
    "render_error",
]
