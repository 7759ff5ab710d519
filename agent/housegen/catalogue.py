"""What a generated house is furnished and filled from: furniture drawn against a wall, object kinds
with their referring descriptions, and which room kinds hold which furniture.

Furniture is given in a wall's own frame, so one template serves every wall: `u` runs along the wall
(positive to the right of someone facing the wall from the room), `v` away from the wall's inner face
into the room, `z` up. The numbers copy the shipped scenes' furniture, which the physics tests carry
objects onto (kitchen_plus's shelf, table, drawer unit, cabinet and fridge; flat's counter and
nightstand); the sofa and the bed are new, with surfaces as low as the TV table's.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

Rgba = tuple[float, float, float, float]


@dataclass(frozen=True)
class Part:
    """A box of a piece: its name, centre (u, v, z) and size (along u, along v, z)."""

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]


@dataclass(frozen=True)
class Spot:
    """A place position on a part's top: its name, its centre (u, v) and size (along u, along v)."""

    name: str
    support: str  # the part's name
    center: tuple[float, float]
    size: tuple[float, float]


@dataclass(frozen=True)
class Piece:
    """A piece of static furniture (boxes) or a container (`container` names its kind)."""

    kind: str
    label: str  # how its location is named, e.g. "Shelf" -> "Kitchen Shelf"
    width: float  # along the wall
    depth: float  # from the wall
    stand: tuple[float, float]  # where the robot stands to use it (u, v)
    color: Rgba
    parts: tuple[Part, ...] = ()
    spots: tuple[Spot, ...] = ()
    container: str | None = None  # drawer, cabinet, fridge
    height: float = 0.0  # a container's


_WOOD: Rgba = (0.55, 0.4, 0.25, 1.0)


def _shelf(layers: tuple[float, ...], width: float) -> Piece:
    depth, top = 0.4, layers[-1] + 0.015
    names = ("bottom", "middle", "top") if len(layers) == 3 else ("lower", "upper")
    parts = [Part(n, (0.0, depth / 2 + 0.03, z), (width, depth, 0.03)) for n, z in zip(names, layers, strict=True)]
    parts += [
        Part("left_side", (-width / 2 - 0.015, depth / 2 + 0.03, top / 2), (0.03, depth, top)),
        Part("right_side", (width / 2 + 0.015, depth / 2 + 0.03, top / 2), (0.03, depth, top)),
        Part("back", (0.0, 0.015, top / 2), (width + 0.06, 0.03, top)),
    ]
    spots = tuple(Spot(n, n, (0.0, 0.28), (width - 0.1, 0.3)) for n in names)
    return Piece("shelf", "Shelf", width + 0.06, depth + 0.03, (0.0, 0.88), _WOOD, tuple(parts), spots)


def _table(width: float, depth: float, height: float, label: str, kind: str) -> Piece:
    legs = tuple(
        Part(
            f"leg_{i + 1}",
            (su * (width / 2 - 0.05), depth / 2 + sv * (depth / 2 - 0.05), (height - 0.02) / 2),
            (0.05, 0.05, height - 0.02),
        )
        for i, (sv, su) in enumerate(((1, -1), (1, 1), (-1, -1), (-1, 1)))
    )
    top = Part("top", (0.0, depth / 2, height), (width, depth, 0.04))
    spot = Spot("middle", "top", (0.0, depth - 0.25), (0.5, 0.4))
    return Piece(kind, label, width, depth, (0.0, depth + 0.35), _WOOD, (top, *legs), (spot,))


#: The furniture catalogue by kind.
FURNITURE: dict[str, Piece] = {
    "shelf": _shelf((0.285, 0.605, 0.925), 1.0),
    "bookcase": replace(_shelf((0.315, 0.675), 0.9), kind="bookcase", label="Bookcase"),
    "table": _table(1.0, 0.6, 0.68, "Table", "table"),
    "desk": _table(1.2, 0.6, 0.72, "Desk", "desk"),
    "counter": Piece(
        "counter",
        "Counter",
        1.6,
        0.53,
        (0.0, 0.81),
        (0.6, 0.5, 0.4, 1.0),
        (Part("worktop", (0.0, 0.28, 0.88), (1.6, 0.5, 0.04)), Part("body", (0.0, 0.26, 0.43), (1.56, 0.46, 0.86))),
        (Spot("left", "worktop", (-0.35, 0.31), (0.5, 0.4)), Spot("right", "worktop", (0.35, 0.31), (0.5, 0.4))),
    ),
    "nightstand": Piece(
        "nightstand",
        "Nightstand",
        0.5,
        0.43,
        (0.0, 0.88),
        (0.5, 0.36, 0.25, 1.0),
        (Part("top", (0.0, 0.23, 0.535), (0.5, 0.4, 0.03)), Part("body", (0.0, 0.23, 0.26), (0.46, 0.36, 0.52))),
        (Spot("top", "top", (0.0, 0.28), (0.4, 0.3)),),
    ),
    "sofa": Piece(
        "sofa",
        "Sofa",
        1.8,
        0.83,
        (0.0, 1.13),
        (0.45, 0.5, 0.62, 1.0),
        (Part("seat", (0.0, 0.53, 0.21), (1.8, 0.6, 0.42)), Part("back", (0.0, 0.13, 0.4), (1.8, 0.2, 0.8))),
        (Spot("left", "seat", (-0.35, 0.63), (0.5, 0.35)), Spot("right", "seat", (0.35, 0.63), (0.5, 0.35))),
    ),
    "bed": Piece(
        "bed",
        "Bed",
        1.9,
        0.93,
        (0.0, 1.28),
        (0.75, 0.78, 0.85, 1.0),
        (Part("frame", (0.0, 0.48, 0.225), (1.9, 0.9, 0.45)),),
        (Spot("top", "frame", (0.0, 0.68), (0.6, 0.35)),),
    ),
    # Containers: the carcass's centre (u, v, z) is the one part. kitchen_plus's drawer unit and fridge; a
    # cabinet is a cupboard the fridge's size (a low, narrow one puts its top and door in the arm's way);
    # the robot 0.4 m from a door's front, 0.75 m from a drawer's (the open drawer's tray 0.54 m away).
    "drawer": Piece(
        "drawer",
        "Drawer",
        0.6,
        0.48,
        (0.0, 1.23),
        (0.62, 0.48, 0.32, 1.0),
        (Part("carcass", (0.0, 0.255, 0.175), (0.6, 0.45, 0.35)),),
        container="drawer",
    ),
    "cabinet": Piece(
        "cabinet",
        "Cabinet",
        0.7,
        0.63,
        (0.15, 1.03),
        (0.55, 0.42, 0.3, 1.0),
        (Part("carcass", (0.0, 0.33, 0.6), (0.7, 0.6, 1.2)),),
        container="cabinet",
    ),
    "fridge": Piece(
        "fridge",
        "Fridge",
        0.7,
        0.63,
        (0.15, 1.03),
        (0.92, 0.93, 0.95, 1.0),
        (Part("carcass", (0.0, 0.33, 0.7), (0.7, 0.6, 1.4)),),
        container="fridge",
    ),
}

#: The kinds of room, the furniture each must have and what it may add (drawn in this order).
ROOM_KINDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "Kitchen": (("counter", "fridge"), ("shelf", "table", "drawer", "cabinet")),
    "Living Room": (("sofa",), ("bookcase", "table", "cabinet", "shelf")),
    "Bedroom": (("bed",), ("nightstand", "drawer", "bookcase")),
    "Study": (("desk",), ("bookcase", "shelf", "drawer", "cabinet")),
    "Dining Room": (("table",), ("cabinet", "shelf", "counter")),
    "Hallway": ((), ("shelf", "cabinet")),
}


@dataclass(frozen=True)
class Kind:
    """A kind of object: its shape and size, mass, colour (None: drawn from the palette), descriptions."""

    name: str
    shape: str  # box, cylinder, urdf
    size: tuple[float, float, float]
    mass: float
    descriptions: tuple[str, ...]
    color: tuple[str, Rgba] | None = None
    urdf: str | None = None
    urdf_scale: float = 1.0
    tags: tuple[str, ...] = field(default=())


#: Ten primitive kinds and four of pybullet_data's models (sizes as measured from their URDFs).
OBJECTS: tuple[Kind, ...] = (
    Kind("cube", "box", (0.08, 0.08, 0.08), 0.2, ("block", "small cube")),
    Kind(
        "parcel",
        "box",
        (0.2, 0.15, 0.12),
        0.5,
        ("package", "delivery", "cardboard box"),
        ("brown", (0.72, 0.55, 0.35, 1.0)),
    ),
    Kind("book", "box", (0.2, 0.14, 0.04), 0.3, ("paperback", "something to read", "novel")),
    Kind("sponge", "box", (0.09, 0.06, 0.04), 0.05, ("dish sponge", "scrubber")),
    Kind("tissues", "box", (0.22, 0.12, 0.1), 0.15, ("tissue box", "box of tissues")),
    Kind("remote", "box", (0.05, 0.16, 0.025), 0.12, ("remote control", "TV remote", "clicker")),
    Kind("bottle", "cylinder", (0.07, 0.07, 0.2), 0.35, ("water bottle", "plastic bottle")),
    Kind("can", "cylinder", (0.066, 0.066, 0.12), 0.3, ("soda can", "tin can", "drink can")),
    Kind("jar", "cylinder", (0.09, 0.09, 0.12), 0.4, ("glass jar", "jam jar")),
    Kind("candle", "cylinder", (0.06, 0.06, 0.1), 0.2, ("wax candle", "pillar candle")),
    Kind(
        "mug",
        "urdf",
        (0.088, 0.128, 0.106),
        0.3,
        ("drinking vessel", "cup", "coffee mug"),
        ("white", (0.95, 0.95, 0.92, 1.0)),
        "objects/mug.urdf",
    ),
    Kind(
        "duck",
        "urdf",
        (0.091, 0.085, 0.066),
        0.1,
        ("rubber duck", "bath toy"),
        ("yellow", (0.95, 0.8, 0.1, 1.0)),
        "duck_vhacd.urdf",
    ),
    Kind(
        "teddy",
        "urdf",
        (0.084, 0.101, 0.071),
        0.1,
        ("teddy bear", "stuffed toy", "soft toy"),
        ("brown", (0.6, 0.42, 0.25, 1.0)),
        "teddy_vhacd.urdf",
    ),
    Kind(
        "brick",
        "urdf",
        (0.068, 0.068, 0.05),
        0.05,
        ("toy brick", "building block", "lego piece"),
        ("red", (0.85, 0.15, 0.15, 1.0)),
        "lego/lego.urdf",
        2.0,
    ),
)

#: Colours the primitive objects are drawn in: a word for the descriptions, and the RGBA.
PALETTE: tuple[tuple[str, Rgba], ...] = (
    ("red", (0.85, 0.15, 0.15, 1.0)),
    ("blue", (0.2, 0.35, 0.8, 1.0)),
    ("green", (0.15, 0.55, 0.3, 1.0)),
    ("purple", (0.55, 0.2, 0.45, 1.0)),
    ("orange", (0.95, 0.55, 0.1, 1.0)),
    ("grey", (0.5, 0.5, 0.52, 1.0)),
    ("pink", (0.95, 0.55, 0.7, 1.0)),
    ("black", (0.1, 0.1, 0.12, 1.0)),
    ("teal", (0.1, 0.6, 0.6, 1.0)),
)
