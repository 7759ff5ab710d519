"""The geometry of furniture that opens (`robocog.shared.scene.Container`), from its dimensions alone.

A container is a carcass (bottom, top, back and two sides) open at its front, and a moving part that
closes the front: a drawer (a tray with a front panel, on a prismatic joint along the facing
direction) or a door (one panel, on a revolute joint about a vertical axis at its hinged edge). Every
panel is a box aligned with the world's axes (a container faces +x, -x, +y or -y), given by its centre
as an offset from the container's centre (the carcass) or from the joint (the moving part), so the
world builds the bodies from these numbers and the layout check reads the same ones.

The joint's position is 0 when closed and grows as it opens, up to `open_q` (metres for a drawer,
radians for a door).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from robocog.shared.scene import Container

Vec3 = tuple[float, float, float]
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1

#: A drawer opens by this fraction of its depth unless `travel` says otherwise; a door by 90 degrees.
DRAWER_TRAVEL = 0.8
DOOR_TRAVEL_DEG = 90.0
#: Below this joint position a drawer (metres) or a door (radians) counts as closed.
CLOSED_M = 0.02
CLOSED_RAD = 0.08
_GAP = 0.005  # between a drawer's tray and its carcass, and under a door or a drawer's front


@dataclass(frozen=True)
class Panel:
    """One box of a container: its centre (an offset, see the module) and its half extents x, y, z."""

    name: str
    center: Vec3
    half: Vec3


@dataclass(frozen=True)
class Geometry:
    """Everything the world and the layout check need of one container, in world axes."""

    spec: Container
    facing: tuple[float, float]  # unit vector of the side the opening faces
    carcass: tuple[Panel, ...]  # offsets from the container's centre
    joint: Literal["prismatic", "revolute"]
    joint_origin: Vec3  # the moving part's frame, as an offset from the container's centre
    axis: Vec3  # the joint's axis: positive positions open
    moving: tuple[Panel, ...]  # offsets from the joint, closed
    handle: Vec3  # the point the hand grips, an offset from the joint, closed
    open_q: float  # the joint position when fully open
    closed_q: float  # at most this: closed
    interior: tuple[Vec3, Vec3]  # low and high corners of the space inside, offsets from the centre, closed
    interior_moves: bool  # a drawer's interior slides out with it

    @property
    def floor_z(self) -> float:
        """Height (world) of the interior's floor, where objects inside rest."""
        return self.spec.center[2] + self.interior[0][2]

    def world(self, offset: Vec3) -> Vec3:
        c = self.spec.center
        return (c[0] + offset[0], c[1] + offset[1], c[2] + offset[2])

    def footprint(self) -> Rect:
        """The carcass's rectangle on the floor (closed, the front panel or door included)."""
        (cx, cy, _), (sx, sy, _) = self.spec.center, self.spec.size
        return (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)

    def swept(self) -> Rect:
        """The floor in front of the opening that the drawer or the door sweeps as it opens fully."""
        fx, fy = self.facing
        lx, ly = fy, -fx
        depth = self.spec.size[0 if fx else 1]
        width = self.spec.size[1 if fx else 0]
        reach = self.open_q + 0.03 if self.joint == "prismatic" else width
        pts = [
            (self.spec.center[0] + fx * f + lx * s, self.spec.center[1] + fy * f + ly * s)
            for f in (depth / 2, depth / 2 + reach)
            for s in (-width / 2, width / 2)
        ]
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        return (min(xs), min(ys), max(xs), max(ys))

    def interior_rect(self) -> Rect:
        """The interior's rectangle on the floor, closed."""
        (lo, hi), (cx, cy, _) = self.interior, self.spec.center
        return (cx + lo[0], cy + lo[1], cx + hi[0], cy + hi[1])

    def is_closed(self, q: float) -> bool:
        return q <= self.closed_q


def geometry(spec: Container) -> Geometry:
    """The panels, joint, handle and interior of a container, from its dimensions."""
    fx, fy = {"+x": (1.0, 0.0), "-x": (-1.0, 0.0), "+y": (0.0, 1.0), "-y": (0.0, -1.0)}[spec.facing]
    lx, ly = fy, -fx  # the left, as seen from the front
    along_x = fx != 0
    sx, sy, height = spec.size
    depth, width = (sx, sy) if along_x else (sy, sx)
    w = spec.wall

    def box(name: str, f: float, s: float, z: float, ef: float, es: float, ez: float) -> Panel:
        """A panel centred `f` along the facing, `s` to the left and `z` up, `ef` x `es` x `ez` in size."""
        half = (ef / 2, es / 2, ez / 2) if along_x else (es / 2, ef / 2, ez / 2)
        return Panel(name, (fx * f + lx * s, fy * f + ly * s, z), half)

    def offset(f: float, s: float, z: float) -> Vec3:
        return (fx * f + lx * s, fy * f + ly * s, z)

    inner_h = height - 2 * w
    carcass = (
        box("bottom", -w / 2, 0, -height / 2 + w / 2, depth - w, width, w),
        box("top", -w / 2, 0, height / 2 - w / 2, depth - w, width, w),
        box("back", -depth / 2 + w / 2, 0, 0, w, width, inner_h),
        box("left", 0, width / 2 - w / 2, 0, depth - 2 * w, w, inner_h),
        box("right", 0, -(width / 2 - w / 2), 0, depth - 2 * w, w, inner_h),
    )
    if spec.kind == "drawer":
        tray_w = width - 2 * w - 2 * _GAP
        z0 = -height / 2 + w + _GAP  # the tray's underside
        z1 = height / 2 - w - _GAP  # the top of its walls
        back_f = -depth / 2 + w + _GAP
        front_f = depth / 2 - w
        wall_z, wall_h = (z0 + w + z1) / 2, z1 - z0 - w
        moving: tuple[Panel, ...] = (
            box("front", depth / 2 - w / 2, 0, 0, w, width, height - 2 * _GAP),
            box("tray_bottom", (back_f + front_f) / 2, 0, z0 + w / 2, front_f - back_f, tray_w, w),
            box("tray_back", back_f + w / 2, 0, wall_z, w, tray_w, wall_h),
            box("tray_left", (back_f + front_f) / 2, tray_w / 2 - w / 2, wall_z, front_f - back_f, w, wall_h),
            box("tray_right", (back_f + front_f) / 2, -(tray_w / 2 - w / 2), wall_z, front_f - back_f, w, wall_h),
            box("handle", depth / 2 + 0.015, 0, 0, 0.03, min(0.15, width / 2), 0.02),
        )
        lo = offset(back_f + w, tray_w / 2 - w, z0 + w)
        hi = offset(front_f, -(tray_w / 2 - w), z1)
        return Geometry(
            spec=spec,
            facing=(fx, fy),
            carcass=carcass,
            joint="prismatic",
            joint_origin=(0.0, 0.0, 0.0),
            axis=(fx, fy, 0.0),
            moving=moving,
            handle=offset(depth / 2 + 0.04, 0, 0),
            open_q=spec.travel if spec.travel is not None else DRAWER_TRAVEL * depth,
            closed_q=CLOSED_M,
            interior=(_low(lo, hi), _high(lo, hi)),
            interior_moves=True,
        )
    side = 1.0 if spec.hinge == "left" else -1.0
    # The door turns about its hinged edge, at the front; its free edge is `side` * width away.
    hinge = offset(depth / 2, side * width / 2, 0)
    rx, ry = -side * lx, -side * ly  # from the hinge towards the free edge
    axis_z = 1.0 if (-ry * fx + rx * fy) > 0 else -1.0  # positive turns swing the free edge out, along the facing
    grip = min(0.06, width / 4)
    moving = (
        box("door", -w / 2, -side * width / 2, 0, w, width, height - 2 * _GAP),
        box("handle", 0.015, -side * (width - grip), 0, 0.03, 0.02, min(0.3, height / 3)),
    )
    lo = offset(-depth / 2 + w, width / 2 - w, -height / 2 + w)
    hi = offset(depth / 2 - w, -(width / 2 - w), height / 2 - w)
    return Geometry(
        spec=spec,
        facing=(fx, fy),
        carcass=carcass,
        joint="revolute",
        joint_origin=hinge,
        axis=(0.0, 0.0, axis_z),
        moving=moving,
        handle=offset(0.04, -side * (width - grip), 0),
        open_q=math.radians(spec.travel if spec.travel is not None else DOOR_TRAVEL_DEG),
        closed_q=CLOSED_RAD,
        interior=(_low(lo, hi), _high(lo, hi)),
        interior_moves=False,
    )


def _low(a: Vec3, b: Vec3) -> Vec3:
    return (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2]))


def _high(a: Vec3, b: Vec3) -> Vec3:
    return (max(a[0], b[0]), max(a[1], b[1]), max(a[2], b[2]))
