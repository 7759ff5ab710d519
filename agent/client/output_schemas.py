"""Output-schema validators compiled once per process, not once per connection.

The MCP SDK's client checks every tool result against the tool's output schema, with a validator it
compiles on a session's first call of the tool, after checking the schema itself against JSON
Schema's metaschema. A study opens a session per worker (and again after a server broke), so it
compiled every tool's validator again for every worker: 27 % of the harness's CPU with 32 workers on
fleets. The validators are immutable, so one per distinct schema serves every session; the SDK still
validates every result.

Validating was the other cost: `jsonschema` walks the schema's `$ref`s in Python, about 1 ms for a
`look_around` result, 7 ms of the harness's CPU per T1 attempt. Each shared validator therefore asks
`jsonschema-rs` (compiled, about 3 µs for the same result) first, and only for a result it rejects
does the SDK's own validator produce the errors, so the message a caller sees is the SDK's, unchanged.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from collections.abc import Iterable, Iterator
from typing import Any

import jsonschema_rs

from robocog.agent.client import compat

#: At most this many distinct schemas are kept (robocog publishes about 20).
LIMIT = 256

_compiled: OrderedDict[str, Any] = OrderedDict()
_lock = threading.Lock()


def share_validators(session: Any, tools: Iterable[Any]) -> int:
    """Give `session` (an `mcp.ClientSession` that has listed `tools`) the validators compiled for
    the same schemas before; compile and keep those not seen yet. Returns how many were reused.
    (Where the SDK keeps its validators elsewhere, `compat.output_validators` finds none: nothing is
    shared and the SDK compiles its own, as before.)"""
    found = compat.output_validators(session)
    if found is None:
        return 0
    validators, compile_one = found
    reused = 0
    for tool in tools:
        schema = getattr(tool, "output_schema", None)
        if not isinstance(schema, dict) or tool.name in validators:
            continue
        key = json.dumps(schema, sort_keys=True)
        with _lock:
            known = _compiled.get(key)
            if known is not None:
                _compiled.move_to_end(key)
        if known is not None:
            validators[tool.name] = known
            reused += 1
            continue
        try:
            compiled = FastValidator.over(compile_one(tool.name, schema), schema)  # the SDK's compile and check
        except RuntimeError:  # an invalid schema: the SDK says so on the tool's first call, as before
            continue
        validators[tool.name] = compiled
        with _lock:
            _compiled[key] = compiled
            while len(_compiled) > LIMIT:
                _compiled.popitem(last=False)
    return reused


class FastValidator:
    """The SDK's `jsonschema` validator, asked only about results the compiled `jsonschema-rs` rejects:
    a valid result (every result of a well-behaved server) costs microseconds, an invalid one gets
    the SDK's own errors. Everything else the SDK may ask of a validator goes to its own."""

    def __init__(self, sdk: Any, fast: Any) -> None:
        self.sdk = sdk
        self.fast = fast

    @classmethod
    def over(cls, sdk: Any, schema: dict[str, Any]) -> Any:
        """`sdk` with the fast check in front, or `sdk` itself for a schema `jsonschema-rs` cannot
        compile (then nothing changes). As with the SDK's, a `$ref` resolves within the schema only
        (`jsonschema-rs` would fetch any other over the network), and formats are not asserted."""
        try:
            fast = jsonschema_rs.validator_for(schema, retriever=_no_retrieval, validate_formats=False)
        except (ValueError, jsonschema_rs.ReferencingError):  # its ValidationError is a ValueError
            return sdk
        return cls(sdk, fast)

    def iter_errors(self, instance: Any) -> Iterator[Any]:
        if self.fast.is_valid(instance):
            return iter(())
        return iter(self.sdk.iter_errors(instance))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.sdk, name)


def _no_retrieval(uri: str) -> Any:
    raise ValueError(f"{uri}: a tool's output schema may only refer within itself")


# --- for robocog's lean client (`lean`), which has no SDK session to give validators to ----------------

_checks: OrderedDict[str, OutputCheck] = OrderedDict()


class OutputCheck:
    """A tool's output schema, compiled once per process: `jsonschema-rs` answers whether a result
    conforms, and only for one that does not does `jsonschema` find the error the SDK would name."""

    def __init__(self, schema: dict[str, Any]) -> None:
        self.schema = schema
        try:
            self.fast: Any = jsonschema_rs.validator_for(schema, retriever=_no_retrieval, validate_formats=False)
        except (ValueError, jsonschema_rs.ReferencingError):
            self.fast = None

    @classmethod
    def of(cls, schema: dict[str, Any]) -> OutputCheck:
        """The process's check for `schema` (compiled on first use, then shared by every session)."""
        key = json.dumps(schema, sort_keys=True)
        with _lock:
            known = _checks.get(key)
            if known is not None:
                _checks.move_to_end(key)
                return known
        made = cls(schema)
        with _lock:
            _checks[key] = made
            while len(_checks) > LIMIT:
                _checks.popitem(last=False)
        return made

    def __call__(self, tool: str, structured: Any, *, present: bool) -> None:
        """Raise what the SDK raises for a result of `tool` whose structured content (`present`: sent
        at all) does not conform: `RuntimeError`, naming the tool and the error."""
        if structured is None and not present:
            raise RuntimeError(f"Tool {tool} has an output schema but did not return structured content")
        if self.fast is not None and self.fast.is_valid(structured):
            return
        from jsonschema import exceptions, validators

        validator = validators.validator_for(self.schema)(self.schema)
        error = exceptions.best_match(validator.iter_errors(structured))
        if error is not None:
            raise RuntimeError(f"Invalid structured content returned by tool {tool}: {error}") from error
