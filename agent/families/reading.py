"""How the scripted planner reads a task: what a reading gives (`Request`: where each object should
end up) and the grounding every family's prompt reader shares — an object named by its name, by a
description the scenes give it ("the drinking vessel") or by where it is ("the item on Kitchen Shelf
top"), and a place named by its location and position — resolved against what the planner's first
look around showed (`FirstLook`, which the planner's `Belief` is; the families sit below the
policies, so they name what they read, not the planner's class).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import yaml

from robocog.assets import ASSETS_DIR
from robocog.shared.names import name_key


class FirstLook(Protocol):
    """What a reader grounds a task in: the world as the first look around showed it
    (`robocog.agent.policies.belief.Belief`)."""

    @property
    def neighbours(self) -> Mapping[str, list[str]]:
        """Location -> the locations it joins."""
        ...

    @property
    def positions(self) -> Mapping[str, list[str]]:
        """Location -> its place positions' names, in order."""
        ...

    @property
    def occupant(self) -> Mapping[tuple[str, str], str | None]:
        """(location, place position) -> the object on it, None when it is free."""
        ...

    @property
    def where(self) -> Mapping[str, tuple[str, str | None]]:
        """Object -> (location, place position or None)."""
        ...

    @property
    def containers(self) -> Mapping[str, str]:
        """Furniture that opens, by name (as look_around lists it) -> the location it is opened from."""
        ...

    def objects(self) -> list[str]:
        """Every object seen, the held one included."""
        ...


@dataclass(frozen=True)
class Goal:
    """Where an object should end up."""

    location: str
    position: str | None = None  # None: any free position of the location


@dataclass(frozen=True)
class Request:
    """What a task asks for: where each object should end up."""

    family: str  # put_away, swap, bring, rearrange, put_back, containers or search: a label for the plan note
    goals: dict[str, Goal]
    all_items: bool = False  # "put away all the items": an object that cannot be grasped is no item
    problem: str | None = None  # why the goals cannot be met, seen before acting
    recall: str | None = None  # an object whose earlier place only memory knows
    close: tuple[str, ...] = ()  # containers to close once the goals are met ("... and close it")
    look_in: tuple[str, ...] = ()  # closed containers that hold goal objects (out of sight until opened)
    explore: bool = False  # the goals name objects and places not seen yet: search the house for them


PREPOSITION = re.compile(r"\b(?:onto|into|to|on|in|at)\b")
ALL_ITEMS = re.compile(r"^(?:all (?:of )?)?(?:the )?(?:items|objects|things)$|^everything$")
_RELATION = re.compile(r"^(?:item|object|thing|one) (?:on|at|in|from) (.+)$")


def clean(text: str) -> str:
    """A phrase as names are compared (`robocog.shared.names.name_key`): lower case, single spaces,
    no surrounding punctuation, no leading article."""
    return name_key(text)


_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@functools.cache
def scene_descriptions() -> dict[str, tuple[str, ...]]:
    """Object name -> the descriptions the hand-made scenes in assets/scenes give it (world knowledge
    the planner, as the suite's oracle, may use to resolve "the drinking vessel")."""
    found: dict[str, list[str]] = {}
    for _, objects in _scene_catalogues(generated=False):
        for name, said in objects.items():
            found.setdefault(name, []).extend(said)
    return {name: tuple(dict.fromkeys(said)) for name, said in found.items()}


@functools.cache
def _scene_catalogues(*, generated: bool) -> tuple[tuple[frozenset[str], dict[str, tuple[str, ...]]], ...]:
    """Per scene file (the hand-made ones, or the generated houses): its location names, and each
    object's descriptions (cleaned)."""
    folder = ASSETS_DIR / "scenes" / ("generated" if generated else "")
    out = []
    for path in sorted(folder.glob("*.yaml")):
        try:
            data = yaml.load(path.read_text(encoding="utf-8"), Loader=_LOADER)
        except (OSError, UnicodeDecodeError, yaml.YAMLError):
            continue
        if not isinstance(data, dict):
            continue
        objects: list[Any] = data["objects"] if isinstance(data.get("objects"), list) else []
        locations: list[Any] = data["locations"] if isinstance(data.get("locations"), list) else []
        said = {
            o["name"]: tuple(dict.fromkeys(clean(str(d)) for d in o.get("descriptions") or []))
            for o in objects
            if isinstance(o, dict) and isinstance(o.get("name"), str)
        }
        names = frozenset(
            loc["name"] for loc in locations if isinstance(loc, dict) and isinstance(loc.get("name"), str)
        )
        out.append((names, said))
    return tuple(out)


def descriptions_in(first: FirstLook) -> dict[str, tuple[str, ...]]:
    """The descriptions of the house the first look shows: a generated house's own (its colours are
    its own: "the red thing" is another object in another house), found by its location and object
    names; the hand-made scenes' otherwise."""
    seen, things = set(first.neighbours), set(first.objects())
    houses = [
        said for names, said in _scene_catalogues(generated=True) if seen and seen <= names and things <= set(said)
    ]
    if len(houses) == 1:
        return houses[0]
    if houses:  # houses alike in every name seen: what all of them call each object
        return {o: tuple(d for d in houses[0][o] if all(d in h.get(o, ()) for h in houses)) for o in houses[0]}
    return scene_descriptions()


def _called(obj: str, descriptions: Mapping[str, tuple[str, ...]]) -> set[str]:
    """What an object may be called: its name (with spaces for underscores) and its descriptions."""
    name = obj.lower()
    return {name, name.replace("_", " "), *descriptions.get(obj, ())}


def _match_location(text: str, locations: list[str]) -> str | None:
    """The location named in `text`: a full name, else the one whose last word is mentioned."""
    low = text.lower()
    for name in sorted(locations, key=len, reverse=True):
        if re.search(rf"\b{re.escape(name.lower())}\b", low):
            return name
    words = set(re.findall(r"[a-z]+", low))
    hits = [n for n in locations if n.lower().split()[-1] in words]
    return hits[0] if len(hits) == 1 else (sorted(hits, key=len)[0] if hits else None)


def place_named(text: str, first: FirstLook) -> Goal | None:
    """The location a phrase names, with the place position it names (if any)."""
    location = _match_location(text, list(first.neighbours))
    if location is None:
        return None
    rest = text.lower().replace(location.lower(), " ")
    position = next(
        (p for p in first.positions.get(location, []) if re.search(rf"\b{re.escape(p.lower())}\b", rest)), None
    )
    return Goal(location, position)


def _by_relation(text: str, first: FirstLook) -> tuple[str | None, str | None]:
    spot = place_named(text, first)
    if spot is None:
        return None, f"there is no place called '{text}'"
    if spot.position is not None:
        found = first.occupant.get((spot.location, spot.position))
        named = f"{spot.location} / {spot.position}"
        return (found, None) if found else (None, f"nothing is on {named}")
    there = [o for o, (loc, _) in first.where.items() if loc == spot.location]
    if len(there) == 1:
        return there[0], None
    return None, (f"nothing is at {spot.location}" if not there else f"several things are at {spot.location}")


def resolve_object(phrase: str, first: FirstLook) -> tuple[str | None, str | None]:
    """(the object a phrase names, None), or (None, why it names none): by name, by a description,
    or by a relation ("the item on Kitchen Shelf top")."""
    text = clean(phrase)
    relation = _RELATION.match(text)
    if relation:
        return _by_relation(relation.group(1), first)
    singular = text[:-1] if text.endswith("s") and not text.endswith("ss") else text
    descriptions = descriptions_in(first)
    hits = [o for o in first.objects() if {text, singular} & _called(o, descriptions)]
    if len(hits) == 1:
        return hits[0], None
    if hits:
        return None, f"'{text}' could be the {' or the '.join(sorted(hits))}"
    return None, f"there is no {text} here"


def object_phrase(phrase: str, first: FirstLook) -> tuple[str | None, str | None]:
    """An object reference that may trail a phrase about where it is ("the cube in the shelf")."""
    found, problem = resolve_object(phrase, first)
    if found or _RELATION.match(clean(phrase)):
        return found, problem
    for cut in reversed(list(PREPOSITION.finditer(phrase))):
        found, problem = resolve_object(phrase[: cut.start()], first)
        if found:
            return found, None
    return None, problem


def destination_split(text: str, first: FirstLook) -> tuple[list[str], Goal | None, str | None]:
    """Split "<objects> <preposition> <place>": (object phrases, where to, why not).

    The first split whose objects all resolve wins (so "the item on Kitchen Shelf top to the
    Living Room" splits at "to"); failing that, the last split that names a place, for its problem."""
    fallback: tuple[list[str], Goal | None, str | None] = ([], None, None)
    for cut in PREPOSITION.finditer(text):
        phrases = [p for p in (clean(x) for x in re.split(r",|\band\b", text[: cut.start()])) if p]
        where = place_named(text[cut.end() :], first)
        if where is None or not phrases:
            continue
        if (len(phrases) == 1 and ALL_ITEMS.match(phrases[0])) or all(resolve_object(p, first)[0] for p in phrases):
            return phrases, where, None
        fallback = (phrases, where, None)
    if fallback[1] is None:
        tail = PREPOSITION.split(text, maxsplit=1)
        fallback = ([], None, f"there is no place called '{clean(tail[-1])}'" if len(tail) > 1 else None)
    return fallback


def objects_named(phrases: list[str], first: FirstLook) -> tuple[list[str], list[str]]:
    """The objects the phrases name, and the problems of those that name none."""
    found = [resolve_object(p, first) for p in phrases]
    return list(dict.fromkeys(o for o, _ in found if o)), [why for o, why in found if o is None and why]
