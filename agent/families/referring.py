"""Referring: the item is named by a description or by where it is (`assets/families/referring.yaml`).
Its prompts are transport prompts, read by the bring family's reader (which grounds such phrases
through `robocog.agent.families.reading.resolve_object`)."""

from __future__ import annotations

import random
from typing import Any

from robocog.agent.families.bring import item_elsewhere, other_location
from robocog.agent.families.registry import draw
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.appearance import attributes
from robocog.shared.family_files import Variant


def noun_phrase(description: str) -> str:
    """A description as a prompt names the thing: "cup" -> "the cup"; one that starts with an article
    or a pronoun ("the heavy thing", "something to read") as it is."""
    text = " ".join(description.split())
    first = text.split()[0].lower()
    return text if first in ("the", "a", "an", "something", "anything") else f"the {text}"


@draw(
    "description_to_location",
    gives={"description": "the drinking vessel", "item": "mug", "location": "Front Door"},
)
def description_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """A graspable item named by one of its scene descriptions only it has ("the cup"), and a location."""
    options = [
        (d, o.name)
        for o in world.scene.objects
        if o.graspable
        for d in o.descriptions
        if world.scene.described_as(d) == [o.name]
    ]
    if not options:
        return None
    description, item = rng.choice(options)
    location = other_location(rng, world, (where[item] or ("", ""))[0])
    if location is None:
        return None
    return {"description": noun_phrase(description), "item": item, "location": location}


@draw(
    "relation_to_location",
    gives={"item": "mug", "item_location": "Kitchen Shelf", "item_position": "top", "location": "Front Door"},
)
def relation_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """A graspable item named by the place position it starts on, and a location."""
    item, spot, location = item_elsewhere(rng, world, where)
    if spot is None or location is None:
        return None
    return {"item": item, "item_location": spot[0], "item_position": spot[1], "location": location}


def seen_words(world: SceneNames) -> dict[str, set[str]]:
    """Every object of the scene (graspable or not) and the words a person may call it by from what
    look_around says of it: its name's words, its colour and its size (`robocog.shared.appearance`)."""
    return {
        o.name: {*o.name.lower().replace("_", " ").split(), *attributes(o.color, o.size)} for o in world.scene.objects
    }


@draw("appearance_to_location", gives={"description": "the white thing", "item": "mug", "location": "Front Door"})
def appearance_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """A graspable item named by what a person sees of it, its colour ("the black thing") or, when
    another object shares the colour, its size and colour ("the small red thing"): a description whose
    every word fits it and no other object of the house (word by word), and a location."""
    words = seen_words(world)
    options = []
    for o in world.scene.objects:
        if not o.graspable:
            continue
        colour, size = attributes(o.color, o.size)
        for said in ([colour], [size, colour]):
            if [n for n, w in words.items() if set(said) <= w] == [o.name]:
                options.append((f"the {' '.join(said)} thing", o.name))
                break
    if not options:
        return None
    description, item = rng.choice(options)
    location = other_location(rng, world, (where[item] or ("", ""))[0])
    if location is None:
        return None
    return {"description": description, "item": item, "location": location}
