"""Every read of a private name of a library the client is built on, in one place.

The MCP SDK (mcp 2.3) and LiteLLM (1.106+) give no public way to a few things the client needs; each
read below names what it reads and why. `tests/integration/test_private_reads.py` runs every one of them
against the installed libraries' real objects and fails, naming the read, when an upgrade moves what
it finds. At run time a read that finds nothing answers as documented (the client then does without:
no shared validators, no cost), so an upgrade degrades a figure, never a run.

- mcp: `ClientSession._tool_output_validators` and `._output_schema_validator`: the validators a
  session compiled, shared between sessions (`output_schemas.share_validators`);
- litellm: `ModelResponse._hidden_params`: where LiteLLM keeps a response's cost (`response_cost`),
  read as the turn's cost and set to None for a model it cannot price;
- litellm: `litellm._async_success_callback` and `._async_failure_callback`: callbacks registered
  for async calls, which keep LiteLLM's success logging on (`litellm_tuning`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

#: LiteLLM's lists of registered callbacks: public, then private (async).
PUBLIC_CALLBACK_LISTS = ("callbacks", "success_callback", "failure_callback")
PRIVATE_CALLBACK_LISTS = ("_async_success_callback", "_async_failure_callback")


def output_validators(session: Any) -> tuple[dict[str, Any], Callable[[str, dict[str, Any]], Any]] | None:
    """A client session's validators by tool name, and the SDK's function that compiles (and checks)
    one; None where the SDK keeps them elsewhere."""
    validators = getattr(session, "_tool_output_validators", None)
    compile_one = getattr(session, "_output_schema_validator", None)
    if not isinstance(validators, dict) or not callable(compile_one):
        return None
    return validators, compile_one


def hidden_params(response: Any) -> dict[str, Any] | None:
    """LiteLLM's hidden parameters of a response (its cost among them); None when it has none."""
    hidden = getattr(response, "_hidden_params", None)
    return hidden if isinstance(hidden, dict) else None


def callbacks_registered(litellm: Any) -> bool:
    """Whether LiteLLM has any success or failure callback registered, globally."""
    return any(getattr(litellm, name, None) for name in (*PUBLIC_CALLBACK_LISTS, *PRIVATE_CALLBACK_LISTS))
