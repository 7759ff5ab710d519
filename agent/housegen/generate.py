"""Drawing a house from a seed: rooms on a grid joined by doors, furniture against the walls, objects
on the place positions; written as a scene YAML in the shipped scenes' schema (`house_yaml`).

Every draw comes from one `random.Random(seed)`, in a fixed order, and every number is rounded, so
one seed gives one file, byte for byte. A draw whose layout the check (`layout_problems`) faults is
drawn again from the same generator; a house that cannot be made sound raises.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

from robocog.agent.housegen.catalogue import FURNITURE, OBJECTS, PALETTE, ROOM_KINDS, Kind, Piece, Rgba
from robocog.shared.containers import geometry
from robocog.shared.scene import Container, Scene
from robocog.shared.scene_layout import layout_problems

#: The grids a house's rooms lie on (rows, columns); the last drops its north-east corner.
GRIDS: tuple[tuple[int, int, bool], ...] = ((1, 2, False), (1, 3, False), (2, 2, False), (1, 4, False), (2, 3, True))
SIZES = (5.0, 5.5, 6.0, 6.5)  # a column's width, a row's depth, metres
DOOR_HALF = 0.6  # half a doorway's width
DOOR_END = 1.4  # a doorway's centre at least this far from a room's corner
CORNER = 1.2  # furniture keeps this far from a room's corners (deeper than any piece)
DOOR_CLEAR = 0.3  # and this far from a doorway
GAP = 0.25  # between two pieces along a wall
MARGIN = 0.07  # from a wall's centre line to a piece's back
ATTEMPTS = 20


def _r(x: float) -> float:
    return round(x + 0.0, 3) + 0.0


@dataclass
class _Side:
    """One wall of a room as furniture sees it: along which axis it runs, where, which way is in."""

    axis: str  # "x": the wall runs along x (north or south)
    lo: float
    hi: float
    wall: float
    inward: int
    sign: int  # +u in world along-axis terms
    facing: str
    free: list[tuple[float, float]]

    def point(self, t: float, u: float, v: float) -> tuple[float, float]:
        along, perp = t + self.sign * u, self.wall + self.inward * (MARGIN + v)
        return (along, perp) if self.axis == "x" else (perp, along)

    def size(self, su: float, sv: float) -> tuple[float, float]:
        return (su, sv) if self.axis == "x" else (sv, su)


def _rgba(c: Rgba) -> list[float]:
    return [float(x) for x in c]


class _House:
    def __init__(self, rng: random.Random, name: str) -> None:
        self.rng, self.name = rng, name
        self.rooms: list[dict[str, Any]] = []
        self.walls: list[dict[str, Any]] = []
        self.locations: list[dict[str, Any]] = []
        self.edges: list[list[str]] = []
        self.furniture: list[dict[str, Any]] = []
        self.containers: list[dict[str, Any]] = []
        self.positions: list[dict[str, Any]] = []
        self.objects: list[dict[str, Any]] = []

    def loc(self, name: str, x: float, y: float) -> None:
        self.locations.append({"name": name, "x": _r(x), "y": _r(y)})

    # -- rooms, walls, doors --------------------------------------------------------------------
    def plan(self) -> list[tuple[str, tuple[float, float, float, float], list[_Side]]]:
        rng = self.rng
        rows, cols, drop = rng.choice(GRIDS)
        xs, ys = [0.0], [0.0]
        for _ in range(cols):
            xs.append(xs[-1] + rng.choice(SIZES))
        for _ in range(rows):
            ys.append(ys[-1] + rng.choice(SIZES))
        cells = [(r, c) for r in range(rows) for c in range(cols) if not (drop and (r, c) == (rows - 1, cols - 1))]
        kinds = ["Kitchen", "Living Room", *rng.sample(["Bedroom", "Study", "Dining Room", "Hallway"], len(cells) - 2)]
        rng.shuffle(kinds)
        names = dict(zip(cells, kinds, strict=True))
        # Doors: a random spanning tree over neighbouring cells, and sometimes one more.
        pairs = [(a, b) for a in cells for b in cells if a < b and abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1]
        rng.shuffle(pairs)
        group = {c: c for c in cells}

        def root(c: tuple[int, int]) -> tuple[int, int]:
            while group[c] != c:
                c = group[c]
            return c

        doors: dict[tuple[tuple[int, int], tuple[int, int]], float] = {}
        spare = []
        for a, b in pairs:
            if root(a) != root(b):
                group[root(a)] = root(b)
                doors[(a, b)] = 0.0
            else:
                spare.append((a, b))
        if spare and rng.random() < 0.5:
            doors[spare[0]] = 0.0
        for a, b in sorted(doors):
            # side by side: the wall runs along y; one above the other: along x
            length = ys[a[0] + 1] - ys[a[0]] if a[0] == b[0] else xs[a[1] + 1] - xs[a[1]]
            doors[(a, b)] = round(rng.uniform(DOOR_END, length - DOOR_END), 1)
        rects = {c: (xs[c[1]], ys[c[0]], xs[c[1] + 1], ys[c[0] + 1]) for c in cells}
        for c in cells:
            x0, y0, x1, y1 = rects[c]
            self.rooms.append(
                {"name": names[c], "x": [_r(x0), _r(x1)], "y": [_r(y0), _r(y1)], "color": _rgba(_ROOM_COLORS[names[c]])}
            )
        sides: dict[tuple[int, int], list[_Side]] = {}
        for c in cells:
            x0, y0, x1, y1 = rects[c]
            sides[c] = [
                _Side("x", x0, x1, y1, -1, 1, "-y", [(x0 + CORNER, x1 - CORNER)]),  # north
                _Side("x", x0, x1, y0, 1, -1, "+y", [(x0 + CORNER, x1 - CORNER)]),  # south
                _Side("y", y0, y1, x0, 1, 1, "+x", [(y0 + CORNER, y1 - CORNER)]),  # west
                _Side("y", y0, y1, x1, -1, -1, "-x", [(y0 + CORNER, y1 - CORNER)]),  # east
            ]
            for k, (dr, dc) in enumerate(((1, 0), (-1, 0), (0, -1), (0, 1))):
                other = (c[0] + dr, c[1] + dc)
                side = sides[c][k]
                door = doors.get((min(c, other), max(c, other)))
                at = None if door is None else (side.lo + door)
                if at is not None:
                    _cut(side, at - DOOR_HALF - DOOR_CLEAR, at + DOOR_HALF + DOOR_CLEAR)
                if other in cells and other < c:
                    continue  # the wall is drawn once, by the room below or to the left
                if at is None:
                    self._wall(side, side.lo, side.hi)
                else:
                    self._wall(side, side.lo, at - DOOR_HALF)
                    self._wall(side, at + DOOR_HALF, side.hi)
        for c in cells:
            x0, y0, x1, y1 = rects[c]
            self.loc(names[c], (x0 + x1) / 2, (y0 + y1) / 2)
        for (a, b), offset in sorted(doors.items()):
            name = f"{names[a]} {names[b]} Door"
            if a[0] == b[0]:
                x, y = xs[b[1]], ys[a[0]] + offset
            else:
                x, y = xs[a[1]] + offset, ys[b[0]]
            self.loc(name, x, y)
            self.edges += [[name, names[a]], [name, names[b]]]
        return [(names[c], rects[c], sides[c]) for c in cells]

    def _wall(self, side: _Side, a: float, b: float) -> None:
        start = (a, side.wall) if side.axis == "x" else (side.wall, a)
        end = (b, side.wall) if side.axis == "x" else (side.wall, b)
        self.walls.append({"start": [_r(start[0]), _r(start[1])], "end": [_r(end[0]), _r(end[1])]})

    # -- furniture ------------------------------------------------------------------------------
    def furnish(self, room: str, rect: tuple[float, float, float, float], sides: list[_Side]) -> None:
        rng = self.rng
        must, may = ROOM_KINDS[room]
        kinds = [*must, *rng.sample(may, rng.randint(1, len(may)))]
        x0, y0, x1, y1 = rect
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        dx, dy = rng.choice(((0.5, 0.0), (-0.5, 0.0), (0.0, 0.5), (0.0, -0.5)))
        self.positions.append(_pos(room, "floor", (cx + dx, cy + dy), (0.4, 0.4), "floor"))
        for kind in kinds:
            piece = FURNITURE[kind]
            fits = [(s, lo, hi) for s in sides for lo, hi in s.free if hi - lo >= piece.width]
            if not fits:
                continue
            side, lo, hi = rng.choice(fits)
            t = lo + piece.width / 2 + round(rng.uniform(0, hi - lo - piece.width) / 0.05) * 0.05
            _cut(side, t - piece.width / 2 - GAP, t + piece.width / 2 + GAP)
            self._piece(room, piece, side, t)

    def _piece(self, room: str, piece: Piece, side: _Side, t: float) -> None:
        key = f"{room} {piece.label}"
        ident = key.lower().replace(" ", "_")
        hinge = self.rng.choice(("left", "right")) if piece.container in ("cabinet", "fridge") else "left"
        su = piece.stand[0] if hinge == "left" else -piece.stand[0]
        self.loc(key, *side.point(t, su, piece.stand[1]))
        self.edges.append([key, room])
        if piece.container is not None:
            part = piece.parts[0]
            x, y = side.point(t, part.center[0], part.center[1])
            spec: dict[str, Any] = {
                "name": ident,
                "kind": piece.container,
                "location": key,
                "center": [_r(x), _r(y), _r(part.center[2])],
                "size": [*map(_r, side.size(*part.size[:2])), _r(part.size[2])],
                "facing": side.facing,
                "color": _rgba(piece.color),
            }
            if piece.container != "drawer":
                spec["hinge"] = hinge
            self.containers.append(spec)
            ix0, iy0, ix1, iy1 = geometry(Container.model_validate(spec)).interior_rect()
            fx, fy = side.point(t, 0.0, part.center[1] + part.size[1] / 2)  # the front's middle
            depth_in = 0.145 if piece.container == "drawer" else 0.15
            px, py = (fx, fy - side.inward * depth_in) if side.axis == "x" else (fx - side.inward * depth_in, fy)
            size = side.size(0.3, 0.15 if piece.container == "fridge" else 0.2)
            px = min(max(px, ix0 + size[0] / 2), ix1 - size[0] / 2)
            py = min(max(py, iy0 + size[1] / 2), iy1 - size[1] / 2)
            self.positions.append(_pos(key, "inside", (px, py), size, ident))
            return
        parts = []
        for part in piece.parts:
            x, y = side.point(t, part.center[0], part.center[1])
            parts.append(
                {
                    "name": part.name,
                    "size": [*map(_r, side.size(*part.size[:2])), _r(part.size[2])],
                    "center": [_r(x), _r(y), _r(part.center[2])],
                    "color": _rgba(piece.color),
                }
            )
        self.furniture.append({"name": ident, "parts": parts})
        for spot in piece.spots:
            self.positions.append(
                _pos(key, spot.name, side.point(t, *spot.center), side.size(*spot.size), f"{ident}/{spot.support}")
            )

    # -- objects --------------------------------------------------------------------------------
    def fill(self) -> None:
        rng = self.rng
        kinds = rng.sample(OBJECTS, rng.randint(6, 9))
        palette = list(PALETTE)
        rng.shuffle(palette)
        colours: list[tuple[str, Rgba]] = []
        for kind in kinds:
            colours.append(kind.color if kind.color is not None else palette.pop())
        spots = list(range(len(self.positions)))
        rng.shuffle(spots)
        words = [c[0] for c in colours]
        for kind, (word, rgba) in zip(kinds, colours, strict=True):
            small = max(kind.size[:2]) <= 0.13
            spot = next(i for i in spots if small or self.positions[i]["name"] != "inside")
            spots.remove(spot)
            pos = self.positions[spot]
            self.objects.append(_object(kind, word, rgba, words.count(word) == 1, pos["location"], pos["name"]))

    def data(self) -> dict[str, Any]:
        start = self.rooms[0]["name"]
        return {
            "name": self.name,
            "robot": "robot/iiwa_mobile.yaml",
            "robot_start": start,
            "rooms": self.rooms,
            "walls": self.walls,
            "locations": self.locations,
            "edges": self.edges,
            "furniture": self.furniture,
            "containers": self.containers,
            "place_positions": self.positions,
            "objects": self.objects,
        }


_ROOM_COLORS: dict[str, Rgba] = {
    "Kitchen": (0.82, 0.88, 0.86, 1.0),
    "Living Room": (0.88, 0.84, 0.88, 1.0),
    "Bedroom": (0.84, 0.86, 0.92, 1.0),
    "Study": (0.9, 0.88, 0.8, 1.0),
    "Dining Room": (0.9, 0.84, 0.8, 1.0),
    "Hallway": (0.86, 0.84, 0.78, 1.0),
}


def _cut(side: _Side, a: float, b: float) -> None:
    out = []
    for lo, hi in side.free:
        if hi <= a or lo >= b:
            out.append((lo, hi))
            continue
        if lo < a:
            out.append((lo, a))
        if b < hi:
            out.append((b, hi))
    side.free = out


def _pos(
    location: str, name: str, center: tuple[float, float], size: tuple[float, float], support: str
) -> dict[str, Any]:
    return {
        "location": location,
        "name": name,
        "center": [_r(center[0]), _r(center[1])],
        "size": [_r(size[0]), _r(size[1])],
        "support": support,
    }


def _object(kind: Kind, word: str, rgba: Rgba, unique: bool, location: str, position: str) -> dict[str, Any]:
    descriptions = [*kind.descriptions, f"{word} {kind.descriptions[0]}"]
    if unique:
        descriptions.append(f"the {word} thing")
    obj: dict[str, Any] = {
        "name": kind.name,
        "shape": kind.shape,
        "size": list(kind.size),
        "mass": kind.mass,
        "color": _rgba(rgba),
    }
    if kind.urdf is not None:
        obj["urdf"] = kind.urdf
        if kind.urdf_scale != 1.0:
            obj["urdf_scale"] = kind.urdf_scale
    obj["descriptions"] = descriptions
    obj["start"] = {"location": location, "position": position}
    return obj


def generate_house(seed: int, name: str | None = None) -> dict[str, Any]:
    """The scene of house `seed` as plain data (the YAML's mapping), sound by the layout check."""
    rng = random.Random(seed)
    name = name or house_name(seed)
    problems: list[str] = []
    for _ in range(ATTEMPTS):
        house = _House(rng, name)
        for room, rect, sides in house.plan():
            house.furnish(room, rect, sides)
        house.fill()
        data = house.data()
        problems = layout_problems(Scene.model_validate(data))
        if not problems:
            return data
    raise ValueError(f"house {seed}: no sound layout in {ATTEMPTS} draws: {problems[:3]}")


def house_name(seed: int) -> str:
    """A generated house's name: `house-007` for seed 7."""
    return f"house-{seed:03d}"
