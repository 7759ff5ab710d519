"""Names a model gives the world tools: the location argument, and the messages for a name that matches nothing.

A suggestion is only a name the model plausibly meant, of the kind the tool takes (see
`navigation.closest`): grab never suggests a location and move_to never an object. When the name
is of the other kind (grab('table'), move_to('mug')) the message says so instead.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import at_most
from robocog.server.world.navigation import closest, resolve, strip_articles
from robocog.shared.limits import NAME_CHARS

if TYPE_CHECKING:
    from robocog.server.world.world import World

LocationArg = Annotated[
    str,
    Field(
        description="A location on the robot's map, as look_around names it, e.g. 'Kitchen Shelf'",
        min_length=1,
        max_length=NAME_CHARS,
    ),
    at_most(NAME_CHARS, "give the location's name as look_around lists it"),
]


def unknown_object(world: World, name: str) -> tuple[str, list[str]]:
    """The failure message for an object name that matches no object, and the objects it may mean."""
    objects = world.object_names
    known = f" Known objects: {', '.join(objects)}."
    bare = strip_articles(name)
    location = resolve(bare, world.map.names)
    if location is not None:
        return f"{name!r} is not an object; {location} is a location.{known}", []
    furniture = _furniture(world, bare)
    if furniture is not None:
        piece, where = furniture
        return f"{name!r} is not an object; the {piece} is furniture at {where}.{known}", []
    suggestions = closest(name, objects)
    if suggestions:
        return f"There is no object called {name!r}. Did you mean {quote_list(suggestions)}?{known}", suggestions
    places = closest(name, world.map.names)
    if not places:
        furnished = world.furniture_locations()
        by_name = {piece.replace("_", " "): where for piece, where in furnished.items()}
        places = list(dict.fromkeys(by_name[p] for p in closest(name, list(by_name))))
    if places:
        are = "is a location" if len(places) == 1 else "are locations"
        return f"{name!r} is not an object; {and_list(places)} {are}.{known}", []
    return f"There is no object called {name!r}.{known}", []


def unknown_location(world: World, name: str) -> tuple[str, list[str]]:
    """The failure message for a location name that matches no location, and the locations it may mean."""
    locations = world.map.names
    known = f" Known locations: {', '.join(locations)}."
    bare = strip_articles(name)
    obj = resolve(bare, world.object_names)
    if obj is not None:
        return f"{name!r} is an object, not a location; {_whereabouts(world, obj)}.{known}", []
    furniture = _furniture(world, bare)
    if furniture is not None:
        piece, where = furniture
        return f"There is no location called {name!r}; the {piece} stands at {where}.{known}", [where]
    suggestions = closest(name, locations)
    guess = f" Did you mean {quote_list(suggestions)}?" if suggestions else ""
    return f"There is no location called {name!r}.{guess}{known}", suggestions


def _furniture(world: World, bare: str) -> tuple[str, str] | None:
    """(display name, location) of the piece of furniture called `bare` exactly, if any."""
    for piece, where in world.furniture_locations().items():
        display = piece.replace("_", " ")
        if resolve(bare, [display]) is not None:
            return display, where
    return None


def _whereabouts(world: World, obj: str) -> str:
    if world.holding == obj:
        return "the robot is holding it"
    where = world.placement(obj).location
    return f"it is at {where}" if where else "it is not at any location"


def quote_list(names: list[str]) -> str:
    """'a', 'b' or 'c'."""
    quoted = [f"'{n}'" for n in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


def and_list(names: list[str]) -> str:
    """a, b and c."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
