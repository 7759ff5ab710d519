"""Infeasible: tasks the robot cannot do (`assets/families/infeasible.yaml`); success is an honest
failure. Its prompts are transport prompts, read by the bring family's reader."""

from __future__ import annotations

import random
from typing import Any

from robocog.agent.families.bring import other_location
from robocog.agent.families.put_away import FURNITURE_EXAMPLE, choose_furniture
from robocog.agent.families.registry import draw
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw("overfill_furniture", gives={"items": ["mug", "box"], **FURNITURE_EXAMPLE})
def overfill_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """One item more than a piece of furniture has place positions: cannot be done."""
    pieces = [p for p in world.furniture() if len(p[1]) < len(world.graspable)]
    if not pieces:
        return None
    name, spots = rng.choice(pieces)
    items = sorted(rng.sample(world.graspable, len(spots) + 1), key=world.graspable.index)
    return {"items": items, "furniture": name, "positions": [list(s) for s in spots]}


@draw("ungraspable_to_furniture", gives={"item": "mug", **FURNITURE_EXAMPLE})
def ungraspable_to_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An object the robot cannot grasp, and a piece of furniture."""
    piece = choose_furniture(rng, world)
    if not world.ungraspable or piece is None:
        return None
    return {"item": rng.choice(world.ungraspable), "furniture": piece[0], "positions": [list(s) for s in piece[1]]}


@draw("absent_to_location", gives={"item": "mug", "location": "Front Door"}, takes=("choices",))
def absent_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """A name from `choices` that no object of the scene has, and a location."""
    absent = [c for c in v.choices if not world.scene.described_as(c)]
    location = other_location(rng, world, None)
    if not absent or location is None:
        return None
    return {"item": rng.choice(absent), "location": location}
