"""Swap: two placed items exchange their place positions (`assets/families/swap.yaml`; T2 of the
paper, from any start)."""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.reading import FirstLook, Goal, Request, clean, object_phrase
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw("pair", gives={"a": "mug", "b": "cube"})
def pair(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """Two graspable items, each on a place position."""
    if len(world.graspable) < 2:
        return None
    a, b = sorted(rng.sample(world.graspable, 2), key=world.graspable.index)
    return {"a": a, "b": b}


@reader(r"^swap (.+)$", order=20)
def read_swap(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """Two objects, each on a place position, to end on each other's."""
    parts = re.split(r"\band\b", match.group(1), maxsplit=1)
    if len(parts) != 2:
        return None
    found = [object_phrase(p, first) for p in parts]
    problems = [why for o, why in found if o is None and why]
    if problems:
        return Request("swap", {}, problem="; ".join(problems))
    a, b = (str(o) for o, _ in found)
    loose = [o for o in (a, b) if not first.where.get(o, ("", None))[1]]
    if loose or a == b:
        same = f"'{clean(parts[0])}' and '{clean(parts[1])}' are the same object"
        why = f"the {loose[0]} is not on a place position" if loose else same
        return Request("swap", {}, problem=why)
    return Request("swap", {a: Goal(*first.where[b]), b: Goal(*first.where[a])})
