"""Memory-dependent: put an item back where it was before the last task (`assets/families/memory.yaml`);
only what the agent remembered says where that was."""

from __future__ import annotations

import random
import re
from typing import Any

from robocog.agent.families.bring import item_elsewhere
from robocog.agent.families.reading import FirstLook, Goal, Request, object_phrase
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw(
    "put_back",
    gives={"item": "mug", "location": "Front Door", "home_location": "Kitchen Table", "home_position": "middle"},
    takes=("prelude",),
)
def put_back(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    """An item a first task moves to a location; the second asks for it back where it was."""
    item, home, location = item_elsewhere(rng, world, where)
    if home is None or location is None:
        return None
    return {"item": item, "location": location, "home_location": home[0], "home_position": home[1]}


def _when(memory: dict[str, Any]) -> str:
    return str(memory.get("when") or "")


def recall_origin(obj: str, memories: list[dict[str, Any]]) -> Goal | None:
    """Where `obj` was before the latest remembered task moved it (the planner's reports say "the mug
    is on Front Door / floor (it was on Kitchen Shelf / bottom)"); None when that task did not say."""
    said = re.compile(rf"\bthe {re.escape(obj)} is on [^;()]+ \(it was on ([^/;()]+?) / ([^;()]+?)\)", re.IGNORECASE)
    latest = max(memories, key=_when, default=None)
    found = said.search(str(latest.get("summary", ""))) if latest else None
    return Goal(found.group(1).strip(), found.group(2).strip()) if found else None


@reader(r"^(?:please )?(?:put|bring|take|move|return) (.+?) back\b", order=10)
def read_put_back(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    """An object to go back where it was before the last task (from memory)."""
    found, problem = object_phrase(match.group(1), first)
    if found is None:
        return Request("put_back", {}, problem=problem)
    # A last task that did not mention the object left it where it was.
    origin = recall_origin(found, memories) or (
        Goal(*first.where[found]) if memories and found in first.where else None
    )
    if origin is None or origin.position is None:
        return Request("put_back", {}, recall=found, problem=f"I do not remember where the {found} was")
    return Request("put_back", {found: origin}, recall=found)
