"""Search: find an object the prompt does not place, under partial observation
(`assets/families/search.yaml`).

look_around shows the robot's own location only (the variants' `observe: location`), and the prompt
says what to find, not where it is ("Find the mug and bring it to the Front Door."): the robot must
explore, looking around as it goes and opening closed containers to look inside, where the object
sometimes is (the draw moves it into one). An instance's `optimal_steps` is the optimum with the
whole house in view: a lower bound, which no search can beat on average.

Its reader reads "find X and bring / put it to / on P" without grounding what the first look cannot
show: the names are the prompt's, and the planner's search grounds them as it sees the house
(`robocog.agent.policies.explore`).
"""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.bring import other_location
from robocog.agent.families.containers import choose_container, move_inside
from robocog.agent.families.put_away import FURNITURE_EXAMPLE
from robocog.agent.families.reading import FirstLook, Goal, Request, clean, place_named, place_words, resolve_object
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant
from robocog.shared.names import name_key

#: How often the object to find starts inside a (closed) container, in a scene that has one.
INSIDE_SHARE = 0.5


def hide(rng: random.Random, world: SceneNames, where: Where) -> str | None:
    """A graspable item to search for, moved into a random container about half the time."""
    if not world.graspable:
        return None
    item = rng.choice(world.graspable)
    box = choose_container(rng, world) if rng.random() < INSIDE_SHARE else None
    if box is not None:
        move_inside(world, where, item, box)
    return item


def _open_air(world: SceneNames, location: str | None) -> bool:
    """Whether `location` has place positions and none inside a container (no opening needed there)."""
    return location is not None and all(s not in world.inside for s in world.spots_at(location))


@draw("hidden_item_to_location", gives={"item": "mug", "location": "Front Door"})
def hidden_item_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item (sometimes inside a container) and a location with place positions, none in a container."""
    item = hide(rng, world, where)
    if item is None:
        return None
    spot = where[item]
    location = other_location(rng, world, spot[0] if spot else None)
    if not _open_air(world, location):
        return None
    return {"item": item, "location": location}


@draw("hidden_item_to_furniture", gives={"item": "mug", **FURNITURE_EXAMPLE})
def hidden_item_to_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item (sometimes inside a container) and a piece of furniture named by its location (all that
    location's positions are the furniture's), which the item is not on."""
    pieces = [(n, s) for n, s in world.furniture() if s == world.spots_at(n)]
    item = hide(rng, world, where)
    if not pieces or item is None:
        return None
    name, spots = rng.choice(pieces)
    if where[item] in spots:
        return None
    return {"item": item, "furniture": name, "positions": [list(s) for s in spots]}


@reader(r"^(?:please )?find (.+?),? and (?:bring|put|place|take|carry|move) it (?:to|on|onto|at) (.+)$", order=50)
def read_search(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """An object to find (by name, or a description when it is in view) and the location to take it to,
    both perhaps out of sight: the planner searches for what it has not seen."""
    phrase, place = match.groups()
    found, _ = resolve_object(phrase, first)
    where = place_named(place, first)
    if where is None or name_key(where.location) != place_words(place):  # the very name ("Living Room" is no sofa)
        where = Goal(place_words(place))
    return Request("search", {found or clean(phrase): where}, explore=True)
