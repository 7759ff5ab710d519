"""What the router reads of a request and says on its own: the JSON-RPC message of a body, the driver
id a call names, a JSON-RPC error response, a line on stderr, and whether a process is stopped.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.shared.protocol import DRIVER_META_KEY, ROBOT_ID_ARG

if TYPE_CHECKING:
    from starlette.responses import Response


def error_response(status: int, message: str, *, code: int = -32603) -> Response:
    from starlette.responses import JSONResponse

    return JSONResponse({"jsonrpc": "2.0", "id": None, "error": {"code": code, "message": message}}, status)


def parse_message(body: bytes) -> dict[str, Any]:
    """The JSON-RPC message of a request body ({} when it is none, or not one message); a body
    nested too deeply raises RecursionError (the caller answers it with a parse error)."""
    if not body:
        return {}
    try:
        message = json.loads(body)
    except ValueError:
        return {}
    return message if isinstance(message, dict) else {}


def driver_name(message: dict[str, Any]) -> str | None:
    """The robot handle a JSON-RPC request presents, if any: a tool call's `robot_id` argument, else
    `params._meta["robocog/driver"]` (the alias robocog's own client sends)."""
    params = message.get("params")
    if not isinstance(params, dict):
        return None
    arguments = params.get("arguments")
    name = arguments.get(ROBOT_ID_ARG) if isinstance(arguments, dict) else None
    if name is None:
        meta = params.get("_meta")
        name = meta.get(DRIVER_META_KEY) if isinstance(meta, dict) else None
    return name if isinstance(name, str) and name else None


#: The tools whose call without a handle mints one on a fleet and binds a robot to it (the read-only
#: robot tools, and reset_world); a test holds this to the server's tools.
MINTING_TOOLS = frozenset({"look_around", "look", "view_scratchpad", "search_memory", "reset_world"})


def mints_handle(message: dict[str, Any]) -> bool:
    """Whether a request without a handle is a tool call that mints one (`MINTING_TOOLS`)."""
    params = message.get("params")
    return (
        message.get("method") == "tools/call"
        and isinstance(params, dict)
        and params.get("name") in MINTING_TOOLS
        and driver_name(message) is None
    )


def say(line: str) -> None:
    """One line on the router's stderr, where the processes' logs go too."""
    print(f"robocog-server: {line}", file=sys.stderr, flush=True)


def is_stopped(pid: int) -> bool:
    """Whether process `pid` is stopped (SIGSTOP), as Linux's /proc says; False where it cannot tell."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[-1].split()[0] in ("T", "t")
