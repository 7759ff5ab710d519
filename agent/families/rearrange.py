"""Rearrange: items to positions each now taken by another of them (`assets/families/rearrange.yaml`);
one has to be parked first."""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.reading import FirstLook, Goal, Request, destination_split, objects_named
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw(
    "cycle",
    gives={"targets": [["mug", "Kitchen Shelf", "top"], ["cube", "Kitchen Shelf", "middle"]]},
    takes=("count",),
)
def cycle(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """`count` items whose target positions are their start positions rotated: one must be parked."""
    assert v.count is not None
    most = min(v.count[1], len(world.graspable))
    if most < max(2, v.count[0]):
        return None
    items = rng.sample(world.graspable, rng.randint(max(2, v.count[0]), most))
    targets = []
    for i, item in enumerate(items):
        spot = where[items[(i + 1) % len(items)]]
        if spot is None:
            return None
        targets.append([item, spot[0], spot[1]])
    return {"targets": targets}


@reader(r"^(?:re)?arrange\b[^:]*:(.+)$", order=30)
def read_arrangement(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """Clauses "X on P", each an object to a place."""
    goals: dict[str, Goal] = {}
    problems: list[str] = []
    for clause in (c for c in re.split(r",|;|\band\b", match.group(1)) if c.strip()):
        phrases, where, problem = destination_split(clause, first)
        objects, missing = objects_named(phrases, first)
        problems += [problem] if problem else missing
        if where is not None:
            goals |= {o: where for o in objects}
    return Request("rearrange", goals, problem="; ".join(problems) or None)
