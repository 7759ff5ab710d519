"""How to build a robot session; light to import (the server answers before the world exists)."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

MemoryLabels = Literal["believed", "verified"]

#: The log level of a failed action or bad input: above info, below warning (MCP's "notice").
NOTICE = 25
logging.addLevelName(NOTICE, "NOTICE")


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
