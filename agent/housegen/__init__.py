"""Generated houses: a seeded, deterministic generator of household scenes (issue 25).

`house_yaml(seed)` is house `seed` as a scene file, in the schema of `robocog.shared.scene` (the world,
the viewers and the planner read it as they read any scene): two to five rooms on a grid joined by
doorways, furniture from a catalogue (`robocog.agent.housegen.catalogue`: shelves, a bookcase, tables,
a desk, a counter, a nightstand, a sofa, a bed, and the containers that open: drawers, cabinets, a
fridge) against the walls, each with a location in front of it, and six to nine objects of fourteen
kinds with their referring descriptions, on place positions. The same seed gives the same bytes; every
house passes `robocog.shared.scene_layout.layout_problems`. The fifty houses robocog ships
(`assets/scenes/generated/house-000.yaml` ... `house-049.yaml`, seeds 0 to 49) are loadable by name.
"""

from __future__ import annotations

from typing import Any

import yaml

from robocog.agent.housegen.generate import generate_house, house_name

__all__ = ["SHIPPED_HOUSES", "generate_house", "house_name", "house_yaml"]

#: How many generated houses robocog ships (seeds 0 .. SHIPPED_HOUSES - 1).
SHIPPED_HOUSES = 50

_SECTIONS = ("rooms", "walls", "locations", "edges", "furniture", "containers", "place_positions", "objects")


def _flow(value: Any) -> str:
    text: str = yaml.safe_dump(value, default_flow_style=True, width=10_000, sort_keys=False)
    return text.removesuffix("...\n").strip()  # a lone scalar ends its document


def house_yaml(seed: int, name: str | None = None) -> str:
    """House `seed` as a scene YAML file's text (byte-identical for the same seed and name)."""
    data = generate_house(seed, name)
    lines = [
        f"# A generated house (robocog scene generate --seed {seed}): do not edit; regenerate it.",
        f"name: {_flow(data['name'])}",
        f"robot: {data['robot']}",
        f"robot_start: {_flow(data['robot_start'])}",
    ]
    for key in _SECTIONS:
        items = data[key]
        if not items:
            lines.append(f"{key}: []")
            continue
        lines.append("")
        lines.append(f"{key}:")
        for item in items:
            if key == "furniture":
                lines.append(f"  - name: {item['name']}")
                lines.append("    parts:")
                lines += [f"      - {_flow(part)}" for part in item["parts"]]
            else:
                lines.append(f"  - {_flow(item)}")
    return "\n".join(lines) + "\n"
