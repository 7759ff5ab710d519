"""The offline "models" without LiteLLM: their turns, answered in-process and cheaply.

- `scripted/planner`: the symbolic planner (the no-key default and the optimal baseline).
- `scripted/overconfident`: sometimes forgets an object and still reports success. The probability
  is `p` in the completion parameters (default 0.3), seeded by `seed`.
- `scripted/refuser`: never acts and never ends the task.
- `scripted/faulty`: commits each error of the taxonomy at a set rate (`rate`, or `rate_<class>`),
  seeded by `seed` (`robocog.agent.policies.faulty`).
- `scripted/without-<tag>`: the planner with one capability taken away, one per capability tag
  (`robocog.agent.policies.ablations`).
- Each scripted model takes `latency_s` (seconds per model turn, default 0) and `jitter_s` (a
  uniform draw in [-jitter_s, +jitter_s] added to it, seeded by `seed` and the turn's number, so
  reproducible) in the completion parameters: a study runs "as if" each turn took real time. The
  wait changes the timing of a run, never its decisions.
- `replay/PATH.jsonl`: replays the assistant turns recorded in a trace file, in order.

The model client answers these strings here (`complete_offline`), so a scripted run or study never
imports LiteLLM (seconds) nor pays its per-call wrapper (milliseconds a turn); `providers` registers
the same turns with LiteLLM for code that calls LiteLLM itself. A response has the shape the loop
reads of LiteLLM's: `choices[0].message` (content, tool_calls), `usage` and `_hidden_params`.
"""

from __future__ import annotations

import json
import math
import random
from dataclasses import dataclass, field
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

from robocog.agent.policies import ablations, faulty
from robocog.agent.policies import is_offline as is_offline  # re-exported: offline.is_offline
from robocog.agent.policies.history import Call, as_dict
from robocog.agent.policies.memo import Kept
from robocog.agent.policies.variants import VARIANTS, decide, is_variant
from robocog.shared.trace import ModelTurn, read_trace

SCRIPTED_MODELS = (*VARIANTS, "faulty", *(f"without-{t}" for t in ablations.TAGS))


class OfflineModelError(ValueError):
    """A request an offline model refuses (an unknown variant, a bad latency, a missing trace): the
    counterpart of a provider's 400, never retried."""


# --- a response in the shape the loop reads --------------------------------------------------------


@dataclass(frozen=True)
class _Function:
    name: str
    arguments: str


@dataclass(frozen=True)
class _ToolCall:
    id: str
    function: _Function
    type: str = "function"


@dataclass(frozen=True)
class _Message:
    content: str | None
    tool_calls: list[_ToolCall] | None
    role: str = "assistant"


@dataclass(frozen=True)
class _Choice:
    message: _Message
    finish_reason: str
    index: int = 0


@dataclass(frozen=True)
class Usage:
    prompt_tokens: int
    completion_tokens: int

    @property
    def total_tokens(self) -> int:
        return self.prompt_tokens + self.completion_tokens


@dataclass
class OfflineResponse:
    """One offline model turn: what the loop reads of a LiteLLM response, and nothing else."""

    model: str
    choices: list[_Choice]
    usage: Usage
    _hidden_params: dict[str, Any] = field(default_factory=dict)


def response(model: str, message: dict[str, Any], prompt_chars: int, cost: float | None) -> OfflineResponse:
    """The response carrying `message` (an OpenAI-style assistant message). Tokens are an estimate
    (4 characters a token): these models read no tokens, but reports stay comparable."""
    calls = [
        _ToolCall(id=c["id"], function=_Function(c["function"]["name"], c["function"]["arguments"]))
        for c in message.get("tool_calls") or []
    ]
    completion_chars = len(json.dumps(message))
    choice = _Choice(
        message=_Message(content=message.get("content"), tool_calls=calls or None),
        finish_reason="tool_calls" if calls else "stop",
    )
    return OfflineResponse(
        model=model,
        choices=[choice],
        usage=Usage(prompt_tokens=prompt_chars // 4, completion_tokens=completion_chars // 4),
        _hidden_params={"response_cost": cost},
    )


#: `json.dumps(..., default=str)`'s encoder, made once.
_ENCODER = json.JSONEncoder(default=str)


#: Conversations measured so far (`prompt_chars`), by the list's id: the list (kept, so no other has
#: its id), the messages measured (the objects), and their characters.
_MEASURED: Kept[int, tuple[list[Any], tuple[Any, ...], int]] = Kept(256)


def prompt_chars(messages: list[Any]) -> int:
    """The characters of the messages, each written as JSON (`json.dumps(m, default=str)`), summed.
    A conversation grows by a few messages a turn: for a list measured before that still holds the
    messages measured then (the same objects, or equal ones), only the new ones are measured. (The
    agent loop never changes a message it holds; a message changed in place after it was measured
    would not be measured again.)"""
    known = _MEASURED.get(id(messages))
    if known is not None and known[0] is messages and tuple(messages[: len(known[1])]) == known[1]:
        total = known[2] + _chars(messages[len(known[1]) :])
    else:
        total = _chars(messages)
    _MEASURED[id(messages)] = (messages, tuple(messages), total)
    return total


def _chars(messages: list[Any]) -> int:
    """`prompt_chars` of `messages`, measured afresh: a message of text fields only is measured once
    (`_text_chars`), and the others are encoded at once (a list's JSON is its items' joined by ", "
    within brackets)."""
    total, rest = 0, []
    for m in messages:
        if type(m) is dict and all(type(k) is str and (v is None or type(v) is str) for k, v in m.items()):
            total += _text_chars(tuple(m.items()))
        else:
            rest.append(m)
    return total + (len(_ENCODER.encode(rest)) - 2 * len(rest) if rest else 0)


@lru_cache(maxsize=4096)
def _text_chars(fields: tuple[tuple[str, str | None], ...]) -> int:
    """The length of a message of these fields (names and texts, in order) as JSON."""
    return len(_ENCODER.encode(dict(fields)))


# --- the scripted models ---------------------------------------------------------------------------


def call_message(call: Call, call_number: int) -> dict[str, Any]:
    """The assistant message carrying the planner's decision (a tool call's text, when it has one, as
    the message's content: `scripted/faulty` logs what it commits there)."""
    if call.name is None:
        return {"role": "assistant", "content": call.text}
    return {
        "role": "assistant",
        "content": call.text or None,
        "tool_calls": [
            {
                "id": f"call_{call_number}",
                "type": "function",
                "function": {"name": call.name, "arguments": json.dumps(call.arguments)},
            }
        ],
    }


def seconds(params: dict[str, Any], name: str, model: str) -> float:
    """A non-negative, finite number of seconds from the completion parameters (0 when absent)."""
    value = params.get(name, (params.get("extra_body") or {}).get(name, 0.0))
    try:
        got = float(value)
    except (TypeError, ValueError):
        got = math.nan
    if not (math.isfinite(got) and got >= 0):
        raise OfflineModelError(f"{model}: {name} must be a non-negative number of seconds, not {value!r}")
    return got


def turn_delay(latency_s: float, jitter_s: float, seed: int | None, turn: int) -> float:
    """How long model turn `turn` (1, 2, ...) of a scripted model takes: `latency_s` plus a uniform
    draw in [-jitter_s, +jitter_s] (never below 0), the same for the same seed and turn. The draw
    has its own generator: the model's decisions do not depend on the latency."""
    if not jitter_s:
        return latency_s
    draw = random.Random(f"latency:{seed}:{turn}").uniform(-jitter_s, jitter_s)
    return max(0.0, latency_s + draw)


def scripted_turn(model: str, messages: list[Any], params: dict[str, Any]) -> tuple[dict[str, Any], float]:
    """`scripted/<variant>`'s answer to `messages` (an assistant message) and how long to wait
    before giving it; `OfflineModelError` for an unknown variant or a bad latency."""
    variant = model.split("/")[-1]
    if variant not in SCRIPTED_MODELS:
        known = ", ".join(f"scripted/{v}" for v in SCRIPTED_MODELS)
        raise OfflineModelError(f"unknown scripted model {model!r}; use one of {known}")
    seed = params.get("seed")
    p = float(params.get("p", (params.get("extra_body") or {}).get("p", 0.3)))
    latency_s, jitter_s = seconds(params, "latency_s", model), seconds(params, "jitter_s", model)
    turns = calls_so_far = 0  # the assistant's turns so far, and the tool calls they made
    for m in map(as_dict, messages):
        if m.get("role") == "assistant":
            turns += 1
            calls_so_far += len(m.get("tool_calls") or [])
    if is_variant(variant):
        call = decide(messages, variant, seed=seed, p=p)
    elif variant.startswith("without-"):
        call = ablations.decide(messages, variant.removeprefix("without-"))
    else:
        try:
            class_rates = faulty.rates(params)
        except (TypeError, ValueError) as exc:
            raise OfflineModelError(f"{model}: {exc}") from None
        call = faulty.decide(messages, seed, class_rates)
    return call_message(call, calls_so_far + 1), turn_delay(latency_s, jitter_s, seed, turns + 1)


# --- replay ----------------------------------------------------------------------------------------


@cache
def _recorded_turns(path: str) -> list[dict[str, Any]]:
    turns = [e.message for e in read_trace(Path(path)) if isinstance(e, ModelTurn)]
    if not turns:
        raise OfflineModelError(f"{path}: the trace holds no model turns to replay")
    return turns


def replay_turn(model: str, messages: list[Any]) -> dict[str, Any]:
    """`replay/PATH.jsonl`: the N-th recorded assistant turn for the N-th model call of a run."""
    path = model.split("/", 1)[1] if model.startswith("replay/") else model
    try:
        turns = _recorded_turns(path)
    except FileNotFoundError:
        raise OfflineModelError(f"replay: no trace file {path!r}") from None
    index = sum(1 for m in map(as_dict, messages) if m.get("role") == "assistant")
    if index >= len(turns):
        return {"role": "assistant", "content": "(the recorded run has no more turns)"}
    return turns[index]


def next_message(model: str, messages: list[Any], params: dict[str, Any]) -> tuple[dict[str, Any], float]:
    """An offline model's next assistant message and the wait before it (scripted models' latency);
    `OfflineModelError` for what it refuses."""
    if model.startswith("replay/"):
        return replay_turn(model, messages), 0.0
    return scripted_turn(model, messages, params)


def offline_turn(model: str, messages: list[Any], params: dict[str, Any]) -> tuple[OfflineResponse, float]:
    """An offline model's response to `messages` and the wait before it (scripted models' latency).
    Scripted turns cost nothing (0.0); a replayed turn's cost is unknown (None)."""
    message, delay = next_message(model, messages, params)
    if model.startswith("replay/"):
        return response(model, message, prompt_chars(messages), None), delay
    return response(f"scripted/{model.split('/')[-1]}", message, prompt_chars(messages), 0.0), delay
