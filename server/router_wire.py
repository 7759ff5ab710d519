"""What the router reads of a request and says on its own: the JSON-RPC message of a body, the driver
id a call names, a JSON-RPC error response, a line on stderr, and whether a process is stopped.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.shared.protocol import DRIVER_META_KEY

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
    """`params._meta["robocog/driver"]` of a JSON-RPC request, if it names one."""
    params = message.get("params")
    meta = params.get("_meta") if isinstance(params, dict) else None
    name = meta.get(DRIVER_META_KEY) if isinstance(meta, dict) else None
    return name if isinstance(name, str) and name else None


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
