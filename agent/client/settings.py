"""The settings of a model's turns: which model, how it is called, and the episode's limits.

Its own module so that the loop, the model service and its error classifier all read it without
importing each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class AgentSettings:
    model: str
    max_invocations: int = 10
    max_steps: int = 60
    timeout_s: float = 180.0
    retries: int = 4
    backoff_s: float = 2.0
    api_base: str | None = None
    api_key: str | None = None
    seed: int | None = None
    temperature: float | None = None
    params: dict[str, Any] = field(default_factory=dict)
    #: The model takes images: a picture a tool returns (look's) is shown to it in a user message
    #: after the tool message; otherwise the tool message says, in one line, that it was left out.
    vision: bool = False
