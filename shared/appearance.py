"""What a person sees of an object: its colour and its size, in words.

robocog-v2.1's look_around names them for every object in view (`robocog.server.tools.look_around`),
and its referring instances name an object by them ("the black thing", "the small red thing"), so a
text-only model can resolve every description from what the tools say. Both sides compute the words
here, from the scene's colour (RGBA) and extents, so the prompt and the tool agree by construction.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

#: The colour words, each at a typical RGB (0-1); an object is called by the nearest one.
PALETTE: dict[str, tuple[float, float, float]] = {
    "black": (0.1, 0.1, 0.1),
    "white": (0.95, 0.95, 0.93),
    "grey": (0.55, 0.55, 0.55),
    "red": (0.8, 0.15, 0.15),
    "orange": (0.95, 0.55, 0.1),
    "yellow": (0.95, 0.85, 0.1),
    "green": (0.2, 0.6, 0.25),
    "teal": (0.1, 0.6, 0.6),
    "blue": (0.15, 0.3, 0.8),
    "purple": (0.55, 0.2, 0.55),
    "pink": (0.95, 0.55, 0.7),
    "brown": (0.55, 0.38, 0.22),
}
#: An object is "small" below this largest extent (metres), "large" from `LARGE_M` on, else "medium".
SMALL_M = 0.12
LARGE_M = 0.3
#: The size words, smallest first.
SIZES = ("small", "medium", "large")


def colour_name(rgba: Sequence[float]) -> str:
    """The colour word nearest an RGBA colour."""
    rgb = tuple(rgba[:3])
    return min(PALETTE, key=lambda name: math.dist(PALETTE[name], rgb))


def size_word(size: Sequence[float]) -> str:
    """'small', 'medium' or 'large', by an object's largest extent."""
    largest = max(size)
    return "small" if largest < SMALL_M else "large" if largest >= LARGE_M else "medium"


def attributes(rgba: Sequence[float], size: Sequence[float]) -> tuple[str, str]:
    """(colour, size) in words."""
    return colour_name(rgba), size_word(size)
