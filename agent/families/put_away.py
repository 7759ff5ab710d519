"""Put away: k of the items onto a named piece of furniture (`assets/families/put_away.yaml`).

Its prompts are transport prompts, read by the bring family's reader."""

from __future__ import annotations

import random
from typing import Any

from robocog.agent.families.registry import draw
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant
from robocog.shared.tasks import Spot

#: A piece of furniture's parameters, as the draws that name one give them.
FURNITURE_EXAMPLE: dict[str, Any] = {
    "furniture": "Kitchen Shelf",
    "positions": [["Kitchen Shelf", "top"], ["Kitchen Shelf", "middle"]],
}


def choose_furniture(rng: random.Random, world: SceneNames) -> tuple[str, list[Spot]] | None:
    """A piece of furniture with place positions (its name in a prompt, its positions), or None."""
    pieces = world.furniture()
    return rng.choice(pieces) if pieces else None


@draw("items_to_furniture", gives={"items": ["mug", "box"], **FURNITURE_EXAMPLE}, takes=("count",))
def items_to_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """k graspable items (`count`) that are not on a piece of furniture with at least k place positions."""
    assert v.count is not None
    piece = choose_furniture(rng, world)
    if piece is None:
        return None
    name, spots = piece
    away = [o for o in world.graspable if where[o] not in spots]
    most = min(v.count[1], len(spots), len(away))
    if most < v.count[0]:
        return None
    items = rng.sample(away, rng.randint(v.count[0], most))
    items.sort(key=world.graspable.index)
    return {"items": items, "furniture": name, "positions": [list(s) for s in spots]}
