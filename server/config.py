"""How to build a robot session; light to import (the server answers before the world exists)."""

from __future__ import annotations

import importlib.util
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

MemoryLabels = Literal["believed", "verified"]
#: What look_around reveals (`robocog.shared.results.Observe`): the robot's location, its room, or the house.
Observe = Literal["location", "room", "house"]

#: The log level of a failed action or bad input: above info, below warning (MCP's "notice").
NOTICE = 25
logging.addLevelName(NOTICE, "NOTICE")

#: HTTP limits by default (`robocog-server --max-sessions`, `--session-idle-s`).
DEFAULT_MAX_SESSIONS = 64
DEFAULT_SESSION_IDLE_S = 600.0
#: How long a fleet keeps a robot bound to a handle that its client never presented (`ownership.py`).
UNCONFIRMED_IDLE_S = 30.0
#: The environment variable that gives a server its driver-id signing secret (`ownership.py`).
DRIVER_SECRET_ENV = "ROBOCOG_DRIVER_SECRET"


def event_loop_options() -> dict[str, Any]:
    """anyio's options for a server's event loop: uvloop's where it is installed (ChromaDB's
    `uvicorn[standard]` brings it everywhere but Windows), asyncio's otherwise. The MCP SDK turns its
    event loop about 16 times a request; on uvloop's a call cost the server 0.06 to 0.26 ms of CPU
    less over stdio (docs/figures.md)."""
    return {"use_uvloop": importlib.util.find_spec("uvloop") is not None}


@dataclass(frozen=True)
class SessionConfig:
    """How to build a session (the server's command line maps onto this)."""

    scene: Path | None = None
    seed: int | None = None
    randomize: bool = False
    gui: bool = False
    data_dir: Path | None = None
    memory_url: str | None = None
    namespace: str = "default"
    memory_labels: MemoryLabels = "believed"
    search_k: int = 3
    observe: Observe = "house"
    #: Fresh splits' cache root (`robocog.shared.seeded_splits`): reset_world(suite="SUITE@SEED") reads it.
    splits: Path | None = None


@dataclass(frozen=True)
class AccessConfig:
    """Who may do what with the robot (the server's command line maps onto this; see server/transport/http.py
    for the HTTP side and server/robots/ownership.py for the lease)."""

    #: A bearer token every HTTP request must carry (None: no authentication, loopback only).
    auth_token: str | None = None
    #: The server's own URL (the issuer of its token, for the SDK's auth settings).
    url: str = "http://127.0.0.1:8765/mcp"
    #: Ask the user (MCP elicitation) before every action that moves the robot.
    confirm_actions: bool = False
    #: The robot tools published (None: all); the eval profile's controls are not affected.
    allow_tools: frozenset[str] | None = None
    #: How long a driver without a session keeps the robot after its last call.
    lease_idle_s: float = DEFAULT_SESSION_IDLE_S
