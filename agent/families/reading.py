"""How the scripted planner reads a task: what a reading gives (`Request`: where each object should
end up) and the grounding every family's prompt reader shares — an object named by its name, by what
look_around said it looks like ("the black thing", "the small red thing": every word of the
description must fit it, and no other object), or by where it is ("the item on Kitchen Shelf top"),
and a place named by its location and position — resolved against what the planner's first look
around showed (`FirstLook`, which the planner's `Belief` is; the families sit below the policies, so
they name what they read, not the planner's class).

The planner learns a house only from what the tools say: nothing here (nor anywhere under
agent/policies, agent/families or agent/symbolic) reads a scene file (an import contract and a test
hold it). A description a house's file gives an object ("the drinking vessel") is not something the
tools say, so the planner does not resolve it: robocog-v2.1's referring instances name what a person
sees.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

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

    @property
    def looks(self) -> Mapping[str, tuple[str, ...]]:
        """Object -> what look_around said it looks like (its colour and size), where it said so."""
        ...

    @property
    def partial(self) -> bool:
        """Whether the first look showed only part of the house (partial observation)."""
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


#: Words of a description that name no attribute ("the black thing": only "black" must fit).
_FILLER = frozenset({"the", "a", "an", "thing", "things", "one", "item", "object", "something", "that", "is"})


def words_of(obj: str, first: FirstLook) -> set[str]:
    """The words an object may be called by from what the tools said of it: its name's words and what
    look_around said it looks like (its colour and size, robocog-v2.1)."""
    return {*obj.lower().replace("_", " ").split(), *first.looks.get(obj, ())}


def _match_location(text: str, locations: list[str], *, loosely: bool = True) -> str | None:
    """The location named in `text`: a full name, else (`loosely`) the one whose last word is mentioned."""
    low = text.lower()
    for name in sorted(locations, key=len, reverse=True):
        if re.search(rf"\b{re.escape(name.lower())}\b", low):
            return name
    if not loosely:
        return None
    words = set(re.findall(r"[a-z]+", low))
    hits = [n for n in locations if n.lower().split()[-1] in words]
    return hits[0] if len(hits) == 1 else (sorted(hits, key=len)[0] if hits else None)


_FLOOR_OF = re.compile(r"^(?:the )?floor of (?:the )?")


def place_words(text: str) -> str:
    """A place as a prompt names it, cleaned, without "the floor of" (a room's floor is the room's
    location: "the floor of the Hall" -> "hall")."""
    return _FLOOR_OF.sub("", clean(text))


def place_named(text: str, first: FirstLook) -> Goal | None:
    """The location a phrase names, with the place position it names (if any). Under partial
    observation a place out of sight is the location the phrase names ("the floor of the Hall": Hall),
    found as the robot explores."""
    known = [*first.neighbours, *(n for ns in first.neighbours.values() for n in ns)]
    location = _match_location(text, list(dict.fromkeys(known)), loosely=not first.partial)
    if location is None:
        if not first.partial or not clean(text):
            return None
        return Goal(place_words(text))
    rest = text.lower().replace(location.lower(), " ")
    position = next(
        (p for p in first.positions.get(location, []) if re.search(rf"\b{re.escape(p.lower())}\b", rest)), None
    )
    left = set(re.findall(r"[a-z]+", rest)) - {"the", "a", "an", "floor", "of"} - set((position or "").split())
    if first.partial and left:  # "Dining Room Counter" is no "Dining Room": a place not seen yet
        return Goal(place_words(text))
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
    named = [o for o in first.objects() if name_key(o) in (text, singular) or name_key(o.replace("_", " ")) == text]
    if named:
        return named[0], None
    wanted = set(text.split()) - _FILLER
    hits = [o for o in first.objects() if wanted and wanted <= words_of(o, first)] if wanted else []
    if len(hits) == 1:
        return hits[0], None
    if hits:
        return None, f"'{text}' could be the {' or the '.join(sorted(hits))}"
    if first.partial and not _RELATION.match(text):  # out of sight yet: the name the prompt gives, to find
        return text, None
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
