"""The paper's tasks as fixed robot action sequences (BRIEF.md: T1, then T2 in the same world): what
`make world-demo` runs, what the tests and benchmarks drive the robot with, written once.

An action is (tool name, *arguments in the order `action_args` names them).
"""

from __future__ import annotations

from typing import Any

#: A robot action: (tool name, *arguments in the order of `action_args`).
Action = tuple[str, ...]

#: T1: look, then cube to the top layer, box to the middle, mug to the bottom (12 actions).
T1_SEQUENCE: tuple[Action, ...] = (
    ("look_around",),
    ("grab", "cube"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "top"),
    ("move_to", "Living Room"),
    ("grab", "box"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "middle"),
    ("move_to", "Kitchen Table"),
    ("grab", "mug"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "bottom"),
)

#: T2 after T1: park the cube on the kitchen floor, move the mug up, bring the cube down.
T2_SEQUENCE: tuple[Action, ...] = (
    ("grab", "cube"),
    ("move_to", "Kitchen Area Left"),
    ("place", "Kitchen Area Left", "floor"),
    ("move_to", "Kitchen Shelf"),
    ("grab", "mug"),
    ("place", "Kitchen Shelf", "top"),
    ("move_to", "Kitchen Area Left"),
    ("grab", "cube"),
    ("move_to", "Kitchen Shelf"),
    ("place", "Kitchen Shelf", "bottom"),
)

#: The argument names of each world action, in order.
ACTION_ARGUMENTS: dict[str, tuple[str, ...]] = {
    "look_around": (),
    "move_to": ("location",),
    "grab": ("object",),
    "place": ("location", "position"),
}


def action_args(action: Action) -> dict[str, Any]:
    """The tool arguments of a (name, *args) world action, by name (`Any`, as `**kwargs` of a call)."""
    name, *args = action
    return dict(zip(ACTION_ARGUMENTS[name], args, strict=True))
