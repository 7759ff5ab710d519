"""Output-schema validators compiled once per process, not once per connection.

The MCP SDK's client checks every tool result against the tool's output schema, with a validator it
compiles on a session's first call of the tool, after checking the schema itself against JSON
Schema's metaschema. A study opens a session per worker (and again after a server broke), so it
compiled every tool's validator again for every worker: 27 % of the harness's CPU with 32 workers on
fleets. The validators are immutable, so one per distinct schema serves every session; the SDK still
validates every result.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from collections.abc import Iterable
from typing import Any

#: At most this many distinct schemas are kept (robocog publishes about 20).
LIMIT = 256

_compiled: OrderedDict[str, Any] = OrderedDict()
_lock = threading.Lock()


def share_validators(session: Any, tools: Iterable[Any]) -> int:
    """Give `session` (an `mcp.ClientSession` that has listed `tools`) the validators compiled for
    the same schemas before; compile and keep those not seen yet. Returns how many were reused.
    (mcp 2.3 keeps a session's validators in `_tool_output_validators`; where it does not, nothing
    is shared and the SDK compiles its own, as before.)"""
    validators = getattr(session, "_tool_output_validators", None)
    compile_one = getattr(session, "_output_schema_validator", None)
    if not isinstance(validators, dict) or compile_one is None:
        return 0
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
            compiled = compile_one(tool.name, schema)  # the SDK's own compile (and check); it keeps it too
        except RuntimeError:  # an invalid schema: the SDK says so on the tool's first call, as before
            continue
        with _lock:
            _compiled[key] = compiled
            while len(_compiled) > LIMIT:
                _compiled.popitem(last=False)
    return reused
