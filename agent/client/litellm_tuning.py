"""What LiteLLM does on every call that does nothing for robocog's model calls, turned off for them.

Two things, neither with a public switch in LiteLLM (its public ones, `turn_off_message_logging`,
`disable_end_user_cost_tracking`, `disable_token_counter` and the like, either change nothing
measurable, cost more, or change a figure), so two of its names are wrapped, once per process
(`tune`), and the wrappers act only inside `complete()`'s calls (`robocog_call`); every other
caller of LiteLLM in the process gets LiteLLM as it is:

- pricing a response whose price `complete()` throws away (a model not in LiteLLM's cost map, whose
  cost robocog records as None: unknown, not free): LiteLLM's cost map, for such a model a search
  through its fallback generalizations and a zero-cost diagnostic, on `ollama_chat/` a
  `POST /api/show`. `litellm.response_cost_calculator` answers None at once instead;
- the success logging after each call when no callback is registered (LiteLLM builds a logging
  payload for callbacks that are not there, on its logging worker): `litellm.utils.
  dispatch_success_logging` returns at once instead. A callback registered in LiteLLM (globally or
  given in a model's `params`) is called as before.

tests/unit/test_litellm_config.py fails if LiteLLM stops calling either name, or if a wrapper
changes a token count, a cost or a callback's call.

Import this module only where LiteLLM is used.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from functools import wraps
from typing import Any

from robocog.agent.client.compat import callbacks_registered

#: Inside `complete()`'s call to a model not in LiteLLM's cost map.
unpriced_call: ContextVar[bool] = ContextVar("robocog_unpriced_call", default=False)
#: Inside `complete()`'s call with no LiteLLM callback registered or given.
unlogged_call: ContextVar[bool] = ContextVar("robocog_unlogged_call", default=False)

#: The keyword arguments by which a call gives LiteLLM callbacks of its own.
CALLBACK_ARGUMENTS = frozenset({"callbacks", "success_callback", "failure_callback", "logger_fn"})
_MARK = "robocog_tuned"


def tune(litellm: Any) -> None:
    """Wrap LiteLLM's cost calculator and success-logging dispatch (once per process)."""
    from litellm import utils

    litellm.response_cost_calculator = _wrapped(litellm.response_cost_calculator, unpriced_call, None)
    utils.dispatch_success_logging = _wrapped(utils.dispatch_success_logging, unlogged_call, None)


def _wrapped(original: Callable[..., Any], skip: ContextVar[bool], answer: Any) -> Callable[..., Any]:
    if getattr(original, _MARK, False):
        return original

    @wraps(original)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if skip.get():
            return answer
        return original(*args, **kwargs)

    setattr(wrapper, _MARK, True)
    return wrapper


@contextmanager
def robocog_call(litellm: Any, *, priced: bool, kwargs: dict[str, Any]) -> Iterator[None]:
    """The scope of one of `complete()`'s calls: not priced when `priced` is False, not logged when
    no callback is registered and `kwargs` give none."""
    logged = callbacks_registered(litellm) or bool(CALLBACK_ARGUMENTS & kwargs.keys())
    unpriced, unlogged = unpriced_call.set(not priced), unlogged_call.set(not logged)
    try:
        yield
    finally:
        unlogged_call.reset(unlogged)
        unpriced_call.reset(unpriced)
