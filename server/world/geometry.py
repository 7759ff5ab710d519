"""The map's geometry as the one map renderer (`assets/viewer/map.js`) draws it: rooms, walls,
furniture, place positions, the semantic map, each object's colour and size, the robot's footprint
and the bounds, as JSON. The live viewer (`/api/scene`) and the robot app (`robot_view`) both send it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from robocog.server.world.world import World


def map_geometry(world: World) -> dict[str, Any]:
    """The scene's geometry for drawing the map of `world` (metres, y up)."""
    scene = world.scene
    points = world.map.points
    xs = [v for r in scene.rooms for v in r.x] + [x for x, _ in points.values()]
    ys = [v for r in scene.rooms for v in r.y] + [y for _, y in points.values()]
    return {
        "name": scene.name,
        "bounds": [min(xs) - 0.5, min(ys) - 0.5, max(xs) + 0.5, max(ys) + 0.5],
        "rooms": [{"name": r.name, "x": list(r.x), "y": list(r.y), "color": list(r.color)} for r in scene.rooms],
        "walls": [{"start": list(w.start), "end": list(w.end), "thickness": w.thickness} for w in scene.walls],
        "furniture": [
            {
                "name": f.name,
                "parts": [{"center": list(p.center[:2]), "size": list(p.size[:2]), "color": list(p.color)}],
            }
            for f in scene.furniture
            for p in f.parts
        ]
        # Furniture that opens, drawn by its carcass (its state is the world's: `furniture` in its state).
        + [
            {
                "name": c.name,
                "parts": [{"center": list(c.center[:2]), "size": list(c.size[:2]), "color": list(c.color)}],
            }
            for c in scene.containers
        ],
        "positions": [
            {"location": p.location, "name": p.name, "center": list(p.center), "size": list(p.size)}
            for p in scene.place_positions
        ],
        "locations": [{"name": name, "x": x, "y": y} for name, (x, y) in points.items()],
        "edges": [list(e) for e in scene.edges],
        "objects": {
            name: {"color": list(world.object_spec(name).color), "size": list(world.object_spec(name).size[:2])}
            for name in world.object_names
        },
        "robot": {"size": list(world.robot_spec.base_size[:2])},
    }
