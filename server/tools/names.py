"""Names a model gives the world tools: the location argument, and the messages for a name that matches nothing."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from robocog.server.world.navigation import closest

LocationArg = Annotated[
    str,
    Field(
        description="A location on the robot's map, as look_around names it, e.g. 'Kitchen Shelf'",
        min_length=1,
        max_length=200,
    ),
]


def unknown(kind: str, name: str, known: list[str]) -> tuple[str, list[str]]:
    """The failure message for a name that matches nothing, and the closest known names."""
    suggestions = closest(name, known)
    guess = f" Did you mean {quote_list(suggestions)}?" if suggestions else ""
    return f"There is no {kind} called {name!r}.{guess} Known {kind}s: {', '.join(known)}.", suggestions


def quote_list(names: list[str]) -> str:
    """'a', 'b' or 'c'."""
    quoted = [f"'{n}'" for n in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
