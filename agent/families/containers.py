"""Containers: items into and out of furniture that opens (`assets/families/containers.yaml`).

A drawer, a cabinet or a fridge hides and shuts away what is inside: the robot must open it (at its
location, the hand free) before it can reach in, so a plan interleaves opening with carrying, and
"... and close it" asks it to finish the job. The draws name a container by its name with spaces
("the kitchen fridge"), as look_around lists it under furniture; an item a variant takes out starts
inside (the draw moves it there, trading places with whatever was inside). A scene without
containers poses none of these.

The prompts are transport prompts ("put X into C", "take X out of C and put it on F", "bring X from
C to L"); this module's reader reads those that name a container, before the bring family's.
"""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.put_away import FURNITURE_EXAMPLE, choose_furniture
from robocog.agent.families.reading import FirstLook, Goal, Request, clean, object_phrase, place_named
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Spot, Where
from robocog.shared.family_files import Variant
from robocog.shared.names import name_key

#: A container's parameters, as the draws that name one give them.
CONTAINER_EXAMPLE: dict[str, Any] = {"container": "kitchen fridge", "positions": [["Kitchen Fridge", "inside"]]}


def spoken(container: str) -> str:
    """A container's name as a prompt says it ("kitchen_fridge" -> "kitchen fridge")."""
    return container.replace("_", " ")


def inside_spots(world: SceneNames, container: str) -> list[Spot]:
    """The place positions inside `container`, in scene order."""
    return [s for s, box in world.inside.items() if box == container]


def choose_container(rng: random.Random, world: SceneNames, kinds: tuple[str, ...] = ()) -> str | None:
    """A container with a place position inside (of one of `kinds`, when given), or None."""
    boxes = sorted(
        c.name for c in world.scene.containers if (not kinds or c.kind in kinds) and inside_spots(world, c.name)
    )
    return rng.choice(boxes) if boxes else None


def move_inside(world: SceneNames, where: Where, item: str, container: str) -> Spot:
    """Put `item` on the first position inside `container` in the start `where` (an object already
    there takes the item's place): the start of a task that takes it out."""
    spot = inside_spots(world, container)[0]
    occupant = next((o for o, s in where.items() if s == spot), None)
    if occupant is not None and occupant != item:
        where[occupant] = where[item]
    where[item] = spot
    return spot


def loose_item(rng: random.Random, world: SceneNames, where: Where) -> str | None:
    """A graspable item that is in no container (so look_around shows it), or None."""
    inside = world.inside
    items = [o for o in world.graspable if (s := where[o]) is not None and s not in inside]
    return rng.choice(items) if items else None


@draw("item_into_container", gives={"item": "mug", "shut": ["kitchen_fridge"], **CONTAINER_EXAMPLE})
def item_into_container(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item in no container, and a container with a free position inside."""
    taken = set(where.values())
    boxes = sorted(b for b in world.containers if any(s not in taken for s in inside_spots(world, b)))
    item = loose_item(rng, world, where)
    if not boxes or item is None:
        return None
    box = rng.choice(boxes)
    spots = inside_spots(world, box)
    positions = [list(s) for s in spots]
    return {"item": item, "container": spoken(box), "shut": [box], "positions": positions}


@draw("item_out_of_drawer", gives={"item": "mug", "container": "kitchen drawer", **FURNITURE_EXAMPLE})
def item_out_of_drawer(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item that starts inside a drawer, and a piece of furniture (no container) to put it on."""
    box = choose_container(rng, world, ("drawer",))
    item = rng.choice(world.graspable) if world.graspable else None
    piece = choose_furniture(rng, world)
    if box is None or item is None or piece is None:
        return None
    move_inside(world, where, item, box)
    name, spots = piece
    return {"item": item, "container": spoken(box), "furniture": name, "positions": [list(s) for s in spots]}


@draw("item_from_cabinet", gives={"item": "mug", "container": "kitchen cabinet", "location": "Front Door"})
def item_from_cabinet(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item that starts inside a cabinet (or a fridge), and a location with place positions in no
    container."""
    box = choose_container(rng, world, ("cabinet", "fridge"))
    item = rng.choice(world.graspable) if world.graspable else None
    if box is None or item is None:
        return None
    spot = move_inside(world, where, item, box)
    inside = world.inside
    options = sorted({loc for s in world.spots if s not in inside for loc in [s[0]]} - {spot[0]})
    if not options:
        return None
    return {"item": item, "container": spoken(box), "location": rng.choice(options)}


_CONTAINER_TASK = (
    r"^(?:please )?(?:put|place|take|bring|get|fetch|move) (.+?) "
    r"(into|out of|from) (?:the )?([a-z ]*?(?:drawer|cabinet|fridge))"
    r"(?:,? and close it| and (?:put|place) it on (.+)| to (.+))?$"
)


@reader(_CONTAINER_TASK, order=35)
def read_container_task(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """ "put X into C [and close it]", "take X out of C and put it on F", "bring X from C to L": the
    container is one look_around lists under furniture (else this is a plain transport prompt, which
    the bring family's reader reads)."""
    phrase, how, said, onto, to = match.groups()
    boxes = {name_key(b): b for b in first.containers}
    box = boxes.get(name_key(said))
    if box is None:
        return Request("containers", {}, problem=f"there is no {clean(said)} that opens here")
    closing = match.group(0).rstrip(".").endswith("and close it")
    item, problem = object_phrase(phrase, first)
    hidden = {box} if how != "into" else set()
    if item is None and hidden:  # out of sight inside: the name as the prompt says it (grounded once seen)
        item = clean(phrase)
    if item is None:
        return Request("containers", {}, problem=problem)
    if how == "into":
        goal: Goal | None = Goal(first.containers[box], None)
    else:
        goal = place_named(onto or to or "", first)
    if goal is None:
        return Request("containers", {}, problem=f"there is no place called '{onto or to}'")
    return Request("containers", {item: goal}, close=(box,) if closing else (), look_in=tuple(sorted(hidden)))
