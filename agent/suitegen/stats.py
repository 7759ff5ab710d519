"""What a suite's splits hold: instances per family and per capability, the scenes they use, and the
distribution of optimal plan lengths per family (`robocog suite list`, the suite bench's figures)."""

from __future__ import annotations

import statistics
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from robocog.shared.family_files import CAPABILITIES
from robocog.shared.suite import Instance


@dataclass(frozen=True)
class PlanLengths:
    """The optimal plan lengths of a family's feasible instances: fewest, median, most, and how many."""

    n: int
    low: int
    median: float
    high: int


def per_family(instances: Iterable[Instance]) -> Counter[str]:
    """Instances per family."""
    return Counter(i.family for i in instances)


def per_capability(instances: Iterable[Instance]) -> dict[str, int]:
    """Instances per capability tag, in `CAPABILITIES`' order (an instance counts under each of its
    tags; tags no instance carries are left out)."""
    counts = Counter(tag for i in instances for tag in i.capabilities)
    return {tag: counts[tag] for tag in CAPABILITIES if counts[tag]}


def plan_lengths(instances: Sequence[Instance]) -> dict[str, PlanLengths]:
    """Per family (in first-seen order), the optimal plan lengths of its feasible instances (an
    infeasible instance's optimum is no action at all, so it is left out)."""
    by_family: dict[str, list[int]] = {}
    for i in instances:
        if i.feasible:
            by_family.setdefault(i.family, []).append(i.optimal_steps)
    return {
        f: PlanLengths(len(steps), min(steps), statistics.median(steps), max(steps)) for f, steps in by_family.items()
    }


def scenes_used(instances: Iterable[Instance]) -> Counter[str]:
    """Instances per scene."""
    return Counter(i.scene for i in instances)
