"""Bounded memories for the scripted planner, which reads the whole conversation again every turn
(`robocog.agent.policies.belief`): what it works out from what has not changed since the last turn is
kept, within a bound, instead of worked out again."""

from __future__ import annotations

import contextlib
from collections.abc import Hashable
from typing import Any, TypeVar

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class Kept(dict[K, V]):
    """A dict that keeps its latest `size` entries: adding one more drops the oldest."""

    def __init__(self, size: int) -> None:
        super().__init__()
        self.size = size

    def __setitem__(self, key: K, value: V) -> None:
        super().__setitem__(key, value)
        if len(self) > self.size:
            with contextlib.suppress(KeyError, StopIteration):  # (another thread may have dropped it)
                del self[next(iter(self))]


def frozen(value: Any) -> Hashable:
    """A JSON value as a hashable one that tells apart what == does not (1, 1.0 and True): a text as
    it is, anything else with its type."""
    if isinstance(value, dict):
        return (dict, tuple((k, v if type(v) is str else frozen(v)) for k, v in value.items()))
    if isinstance(value, list | tuple):
        return (type(value), tuple(v if type(v) is str else frozen(v) for v in value))
    return value if type(value) is str else (type(value), value)
