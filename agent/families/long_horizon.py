"""Long horizon: tidy a house, eight or more items each to a place position in another room
(`assets/families/long_horizon.yaml`); an optimal plan of 30 or more robot actions.

Its prompt lists the arrangement ("Tidy the house: the mug on Kitchen Shelf top, ..."), read by the
rearrange family's clause reader: what it measures is carrying a long plan through without dropping
a step, not guessing where things belong.
"""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.reading import FirstLook, Request
from robocog.agent.families.rearrange import read_arrangement
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw(
    "tidy_rooms",
    gives={"targets": [["mug", "Kitchen Shelf", "top"], ["cube", "Living Room Table", "middle"]]},
    takes=("count",),
)
def tidy_rooms(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """`count` items (as many as the scene has, up to its most), each to a free place position in the
    open (not inside a container) of a room other than the one it starts in, no two to the same
    position and none to a position a bystander holds; None when the scene has too few items or rooms."""
    assert v.count is not None
    most = min(v.count[1], len(world.graspable))
    if most < v.count[0] or len(world.scene.rooms) < 2:
        return None
    items = sorted(rng.sample(world.graspable, rng.randint(v.count[0], most)), key=world.graspable.index)
    held = {where[o] for o in world.graspable if o not in items}
    taken: set[tuple[str, str]] = set()
    targets = []
    for item in items:
        spot = where[item]
        if spot is None:
            return None
        home = world.room_of(spot[0])
        options = [s for s in world.open_spots if s not in held | taken and world.room_of(s[0]) != home]
        if not options:
            return None
        target = rng.choice(options)
        taken.add(target)
        targets.append([item, target[0], target[1]])
    return {"targets": targets}


@reader(r"^tidy (?:up )?the (?:house|flat|home)\b[^:]*:(.+)$", order=25)
def read_tidy(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """Clauses "X on P", each an object to a place (the rearrange family's reading)."""
    return read_arrangement(match, first, memories)
