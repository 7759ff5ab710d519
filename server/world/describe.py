"""The environment description in words: every location with its objects, place positions and
neighbours, then where the robot is. The paper's task message carries one before every task
(the `robocog://world/description` resource serves it, for harnesses that follow the paper).

Generated from the scene and the ground truth, in scene order, so the same world always reads
the same. Occupancy is the physics' (what lies on a position now), not bookkeeping.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robocog.server.world.world import World

#: The first line of the description.
HEADER = "These are the locations in the world:"


def describe(world: World) -> str:
    """The world in words, one line per fact:

    ```
    These are the locations in the world:
    - Front Door
      - Objects here:
        - cube
      - Place positions here:
        - floor: occupied by cube
      - Connected locations:
        - Hallway Area Door
    ...
    You are at: Front Door
    ```

    An empty list reads "none"; the object in the robot's hand is listed at the robot's location,
    marked "(in your hand)". What a closed drawer, cabinet or fridge holds is not listed, nor are the
    place positions inside it.
    """
    placements = world.placements()
    here, held = world.robot_location(), world.holding
    lines = [HEADER]
    for name in world.map.names:
        objects = [
            f"{p.object} (in your hand)" if p.object == held else p.object
            for p in placements.values()
            if p.location == name and not world.hidden(p)
        ]
        positions = [f"{pos}: {_occupancy(world, name, pos)}" for pos in world.visible_positions(name)]
        lines.append(f"- {name}")
        lines += _block("Objects here", objects)
        lines += _block("Place positions here", positions)
        lines += _block("Connected locations", world.map.neighbours[name])
    lines.append(f"You are at: {here}")
    return "\n".join(lines)


def _occupancy(world: World, location: str, position: str) -> str:
    occupant = world.occupant(location, position)
    return f"occupied by {occupant}" if occupant else "empty"


def _block(title: str, items: list[str]) -> list[str]:
    if not items:
        return [f"  - {title}: none"]
    return [f"  - {title}:", *(f"    - {item}" for item in items)]
