"""Bring: one item to a named location (`assets/families/bring.yaml`), the suite's baseline.

Its reader reads every transport prompt ("put / place / bring / take / move ... X to P"), so also
those of put_away, referring and infeasible; its `other_location` serves their draws too.
"""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.reading import ALL_ITEMS, FirstLook, Request, destination_split, objects_named
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant

#: The verbs that put things away rather than bring them (the plan note's label).
_PUTTING = {"put", "place", "set", "tidy", "clear"}


def other_location(rng: random.Random, world: SceneNames, location: str | None) -> str | None:
    """A location with place positions in the open (not inside a container), other than `location`."""
    options = sorted({loc for loc, _ in world.open_spots} - {location or ""})
    return rng.choice(options) if options else None


def item_elsewhere(
    rng: random.Random, world: SceneNames, where: Where
) -> tuple[str, tuple[str, str] | None, str | None]:
    """A graspable item, where it is (None: held), and a location with place positions where it is
    not (None: there is none)."""
    item = rng.choice(world.graspable)
    spot = where[item]
    return item, spot, other_location(rng, world, spot[0] if spot else None)


@draw("item_to_location", gives={"item": "mug", "location": "Front Door"})
def item_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """A graspable item and a location with place positions where it is not."""
    item, _, location = item_elsewhere(rng, world, where)
    return None if location is None else {"item": item, "location": location}


@reader(r"^(?:please )?(put|place|set|tidy|clear|bring|take|carry|move|get)\b", order=40)
def read_transport(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """Objects (by name, description or relation, or "all the items") to a place."""
    verb, text = match.group(1), match.string[match.end() :]
    phrases, where, problem = destination_split(re.sub(r"\baway\b", " ", text), first)
    if problem:
        return Request("bring", {}, problem=problem)
    if where is None:
        return None
    family = "put_away" if verb in _PUTTING else "bring"
    if len(phrases) == 1 and ALL_ITEMS.match(phrases[0]):
        items = [o for o in first.objects() if first.where.get(o, ("", None))[0] != where.location]
        return Request("put_away", {o: where for o in items}, all_items=True)
    objects, problems = objects_named(phrases, first)
    return Request(family, {o: where for o in objects}, problem="; ".join(problems) or None)
