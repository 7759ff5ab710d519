"""The geometry a scene's schema cannot see: `layout_problems` checks a connected map, nothing
overlapping, positions on their supports and within reach; every shipped scene passes it."""

from __future__ import annotations

import math

from robocog.shared.config_files import Vec2
from robocog.shared.containers import Geometry, geometry
from robocog.shared.scene import Scene, Wall

#: Metres from a location to the centre of one of its place positions that the arm reaches (the
#: shipped scenes keep 0.6 to 0.67; the physics decides, this only catches a position put far off).
REACH_M = 0.7
#: Half the width of the robot's base: a location closer than this to a wall or furniture is cramped.
BASE_HALF_M = 0.25
_Rect = tuple[float, float, float, float]  # x0, y0, x1, y1


def _rect(center: tuple[float, ...], size: tuple[float, ...]) -> _Rect:
    return (center[0] - size[0] / 2, center[1] - size[1] / 2, center[0] + size[0] / 2, center[1] + size[1] / 2)


def _overlap(a: _Rect, b: _Rect, slack: float = 1e-6) -> bool:
    """Whether two rectangles overlap by more than `slack` in x and in y (touching is not overlapping)."""
    return min(a[2], b[2]) - max(a[0], b[0]) > slack and min(a[3], b[3]) - max(a[1], b[1]) > slack


def _point_segment(px: float, py: float, a: Vec2, b: Vec2) -> float:
    (ax, ay), (bx, by) = a, b
    dx, dy = bx - ax, by - ay
    t = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(px - (ax + t * dx), py - (ay + t * dy))


def _rect_wall_gap(r: _Rect, wall: Wall) -> float:
    """Distance from a rectangle to a wall's surface in the plan (negative or zero when they meet)."""
    x0, y0, x1, y1 = r
    a, b = wall.start, wall.end
    inside = any(x0 <= px <= x1 and y0 <= py <= y1 for px, py in (a, b))
    if not inside:
        # The segment crosses the rectangle when it crosses a diagonal's line within both.
        for (cx, cy), (ex, ey) in (((x0, y0), (x1, y1)), ((x0, y1), (x1, y0))):
            d1 = (b[0] - a[0]) * (cy - a[1]) - (b[1] - a[1]) * (cx - a[0])
            d2 = (b[0] - a[0]) * (ey - a[1]) - (b[1] - a[1]) * (ex - a[0])
            d3 = (ex - cx) * (a[1] - cy) - (ey - cy) * (a[0] - cx)
            d4 = (ex - cx) * (b[1] - cy) - (ey - cy) * (b[0] - cx)
            if d1 * d2 < 0 and d3 * d4 < 0:
                inside = True
    if inside:
        return -wall.thickness / 2
    corners = [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]
    gap = min(_point_segment(px, py, a, b) for px, py in corners)
    for px, py in (a, b):
        gap = min(gap, math.hypot(max(x0 - px, 0.0, px - x1), max(y0 - py, 0.0, py - y1)))
    return gap - wall.thickness / 2


def layout_problems(scene: Scene) -> list[str]:
    """What is physically wrong with a scene's layout, one line each (none for a sound scene).

    The schema checks names and references; this checks the geometry a world needs: every location
    reachable from the robot's start over the edges, inside a room and clear of walls and furniture;
    no two pieces of furniture, nor furniture and a wall, overlapping; each place position on its
    support (a furniture part's top, a container's interior, or free floor), within the arm's reach of
    its location (a drawer's where the drawer is open), and apart from the other positions on the same
    surface; and each container clear of walls, furniture and other containers, with the floor its
    drawer or door sweeps as it opens clear of them too (`container_problems`).
    """
    problems: list[str] = []
    # The navigation graph is connected.
    neighbours: dict[str, set[str]] = {loc.name: set() for loc in scene.locations}
    for a, b in scene.edges:
        neighbours[a].add(b)
        neighbours[b].add(a)
    seen, todo = {scene.robot_start}, [scene.robot_start]
    while todo:
        for nxt in neighbours[todo.pop()] - seen:
            seen.add(nxt)
            todo.append(nxt)
    cut_off = [loc.name for loc in scene.locations if loc.name not in seen]
    if cut_off:
        problems.append(f"locations {cut_off} cannot be reached from {scene.robot_start!r} over the edges")
    boxes = [(f"{f.name}/{p.name}", f.name, p) for f in scene.furniture for p in f.parts]
    footprints = {key: _rect(p.center, p.size) for key, _, p in boxes}
    problems += container_problems(scene, footprints)
    # Furniture against furniture and walls.
    for i, (key, owner, _) in enumerate(boxes):
        for other, other_owner, _ in boxes[i + 1 :]:
            if owner != other_owner and _overlap(footprints[key], footprints[other]):
                problems.append(f"furniture {key} overlaps {other}")
        for j, wall in enumerate(scene.walls):
            if _rect_wall_gap(footprints[key], wall) < -1e-6:
                problems.append(f"furniture {key} overlaps walls[{j}]")
    # Locations: in a room, clear of walls and furniture.
    for loc in scene.locations:
        if scene.rooms and not any(r.x[0] <= loc.x <= r.x[1] and r.y[0] <= loc.y <= r.y[1] for r in scene.rooms):
            problems.append(f"location {loc.name!r} is in no room")
        base = _rect((loc.x, loc.y), (2 * BASE_HALF_M, 2 * BASE_HALF_M))
        for j, wall in enumerate(scene.walls):
            if _rect_wall_gap(base, wall) < -1e-6:
                problems.append(f"location {loc.name!r}: the robot would stand in walls[{j}]")
        for key, _, _ in boxes:
            if _overlap(base, footprints[key]):
                problems.append(f"location {loc.name!r}: the robot would stand in furniture {key}")
        for box in scene.containers:
            if _overlap(base, _rect(box.center, box.size)):
                problems.append(f"location {loc.name!r}: the robot would stand in container {box.name}")
    # Place positions: on their support, in reach, apart.
    containers = {box.name: geometry(box) for box in scene.containers}
    for i, pos in enumerate(scene.place_positions):
        label = f"place position {pos.location} / {pos.name}"
        region = _rect(pos.center, pos.size)
        loc = scene.location(pos.location)
        cx, cy = pos.center
        if pos.support in containers and containers[pos.support].interior_moves:
            cx, cy = _opened(containers[pos.support], cx, cy)  # the robot reaches into the open drawer
        far = math.hypot(cx - loc.x, cy - loc.y)
        if far > REACH_M:
            problems.append(f"{label}: {far:.2f} m from its location, past the arm's reach ({REACH_M} m)")
        if pos.support in containers:
            x0, y0, x1, y1 = containers[pos.support].interior_rect()
            if not (x0 <= region[0] and region[2] <= x1 and y0 <= region[1] and region[3] <= y1):
                problems.append(f"{label}: its region is not inside {pos.support}")
        elif pos.support == "floor":
            for box in scene.containers:
                if _overlap(region, _rect(box.center, box.size)):
                    problems.append(f"{label}: the floor there is under container {box.name}")
            for key, _, _ in boxes:
                if _overlap(region, footprints[key]):
                    problems.append(f"{label}: the floor there is under furniture {key}")
            for j, wall in enumerate(scene.walls):
                if _rect_wall_gap(region, wall) < -1e-6:
                    problems.append(f"{label}: overlaps walls[{j}]")
        else:
            x0, y0, x1, y1 = footprints[pos.support]
            if not (x0 <= pos.center[0] <= x1 and y0 <= pos.center[1] <= y1):
                problems.append(f"{label}: its centre is not over {pos.support}")
        for later in scene.place_positions[i + 1 :]:
            if later.support == pos.support and _overlap(region, _rect(later.center, later.size)):
                problems.append(f"{label} overlaps {later.location} / {later.name} on {pos.support}")
    return problems


def _opened(g: Geometry, x: float, y: float) -> tuple[float, float]:
    """Where a point of a drawer's interior is when the drawer is fully open."""
    return x + g.facing[0] * g.open_q, y + g.facing[1] * g.open_q


def container_problems(scene: Scene, furniture: dict[str, _Rect]) -> list[str]:
    """What stops a container from standing or opening: its carcass, or the floor its drawer or door
    sweeps as it opens fully, overlapping a wall, furniture (`furniture`: footprints by part) or another
    container (carcass or sweep), and its interior out of the arm's reach from its location."""
    problems: list[str] = []
    shapes = [geometry(box) for box in scene.containers]
    for i, g in enumerate(shapes):
        name = g.spec.name
        for what, rect in (("", g.footprint()), ("the sweep of ", g.swept())):
            for key, part in furniture.items():
                if _overlap(rect, part):
                    problems.append(f"container {name}: {what}it overlaps furniture {key}")
            for j, wall in enumerate(scene.walls):
                if _rect_wall_gap(rect, wall) < -1e-6:
                    problems.append(f"container {name}: {what}it overlaps walls[{j}]")
            for later in shapes[i + 1 :]:
                for their, later_rect in (("", later.footprint()), ("the sweep of ", later.swept())):
                    if what and their:
                        continue  # two sweeps may share floor: only one opens at a time
                    if _overlap(rect, later_rect):
                        problems.append(f"container {name}: {what}it overlaps {their}container {later.spec.name}")
        loc = scene.location(g.spec.location)
        x0, y0, x1, y1 = g.interior_rect()
        if g.interior_moves:  # a drawer's interior is reached where the drawer is open
            (x0, y0), (x1, y1) = _opened(g, x0, y0), _opened(g, x1, y1)
        near = math.hypot(max(x0 - loc.x, 0.0, loc.x - x1), max(y0 - loc.y, 0.0, loc.y - y1))
        if near > REACH_M:
            problems.append(
                f"container {name}: its interior is {near:.2f} m from {g.spec.location}, past the arm's reach"
            )
    return problems
