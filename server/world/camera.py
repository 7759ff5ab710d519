"""The robot's camera: an egocentric RGB view rendered headless, and what it sees from ground truth.

The camera sits on a pan-tilt head on a mast at the middle of the robot's base: the lens is
`MOUNT_HEIGHT_M` above the floor and `LENS_OFFSET_M` out from the mast along the way it looks (past
the base's edge and clear of the tucked arm). It looks along the robot's heading (the base's yaw;
the omnidirectional base drives without turning, so it keeps the heading it starts with), to its
left, right or behind, or turns toward a named location or object. The vertical field of view is
`FOV_DEG` (about 75 degrees across at 4:3).

Rendering uses PyBullet's TinyRenderer (software, no display, no GPU) without shadows, and reads
the simulation only: nothing is stepped or moved. Its cost is its pixel fill and the triangles of
every mesh, so a frame is drawn at `raster.RENDER_SCALE` of each side and scaled up (bilinear for the
colours, nearest for the body ids and depth; at 320x240 that is 240x180), without the robot's arm
when the arm is out of the frame (see `raster`). Like every reading of a world, call it from the
one thread that drives the world (the server's lock).

    view = capture(world, "ahead")        # pixels, segmentation, depth and the camera's pose
    png = encode_png(view.rgb)            # PNG bytes
    png = render_camera(world, direction="left", width=320, height=240)  # both in one call
    caption(world, view)                  # what is visible, from the segmentation (ground truth)
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pybullet

from robocog.server.world import raster, truth
from robocog.server.world.navigation import closest, resolve, strip_articles
from robocog.server.world.world import World
from robocog.shared.results import Caption, SeenObject

#: The default image size, in pixels (4:3).
WIDTH, HEIGHT = 320, 240
#: The largest image either side may be (a software renderer's time grows with the pixels).
MAX_SIDE = 1024
#: The lens: its height above the floor, its distance out from the mast, its vertical field of view.
MOUNT_HEIGHT_M = 1.3
LENS_OFFSET_M = 0.3
FOV_DEG = 60.0
#: The horizontal field of view at the default 4:3 size (degrees).
FOV_ACROSS_DEG = math.degrees(2 * math.atan(math.tan(math.radians(FOV_DEG / 2)) * WIDTH / HEIGHT))
#: The tilt when looking in a direction (not at a target): down, to show the floor up to a few metres.
TILT_DEG = -20.0
#: The tilt toward a target stays within these (degrees, up is positive).
TILT_RANGE = (-60.0, 20.0)
NEAR_M, FAR_M = 0.05, 25.0
#: Directions relative to the robot's heading, as angles to its left (degrees).
DIRECTIONS: dict[str, float] = {"ahead": 0.0, "left": 90.0, "right": -90.0, "behind": 180.0}
#: Fewer pixels than this of a body do not count as seeing it.
MIN_PIXELS = 6

Image = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class Aim:
    """Where the camera points: a resolved direction, its heading and tilt in the map frame (degrees;
    heading 0 is +x, counter-clockwise) and, when it turned toward something, that target's name."""

    direction: str
    heading_deg: float
    tilt_deg: float
    target: str | None = None
    note: str = ""


@dataclass(frozen=True)
class CameraView:
    """One rendered frame: RGB pixels (height x width x 3), the body id seen at each pixel (-1:
    nothing), the distance along the view axis at each pixel (metres), and the camera's pose."""

    aim: Aim
    rgb: Image
    segmentation: npt.NDArray[np.int32]
    depth_m: npt.NDArray[np.float32]
    eye: tuple[float, float, float]
    view_matrix: tuple[float, ...]
    projection_matrix: tuple[float, ...]

    @property
    def width(self) -> int:
        return int(self.rgb.shape[1])

    @property
    def height(self) -> int:
        return int(self.rgb.shape[0])


def directions_help(world: World) -> str:
    """What `aim` accepts, in one sentence."""
    return (
        f"a direction ({', '.join(DIRECTIONS)}), a location ({', '.join(world.map.names)}) "
        f"or an object ({', '.join(world.object_names)})"
    )


def aim(world: World, direction: str = "ahead") -> Aim:
    """The camera's aim for `direction`: one of `DIRECTIONS` (relative to the robot's heading), or
    toward a location or an object of the scene (names as the tools take them, articles and case
    do not matter). A ValueError names what is accepted and the names `direction` may have meant."""
    robot = world.sim.robot
    heading = math.degrees(robot.yaw)
    word = strip_articles(direction)
    relative = resolve(word, list(DIRECTIONS))
    if relative is not None:
        return Aim(relative, _wrap(heading + DIRECTIONS[relative]), TILT_DEG)
    obj = resolve(word, world.object_names)
    location = resolve(word, world.map.names)
    if obj is None and location is None:
        guesses = closest(direction, [*DIRECTIONS, *world.map.names, *world.object_names])
        guess = f" Did you mean {' or '.join(repr(g) for g in guesses)}?" if guesses else ""
        raise ValueError(f"cannot look toward {direction!r}.{guess} Give {directions_help(world)}.")
    if obj is not None:
        target = world.placement(obj).xyz
        name = obj
    else:
        assert location is not None
        target, name = _location_target(world, location), location
    dx, dy = target[0] - robot.x, target[1] - robot.y
    if math.hypot(dx, dy) < LENS_OFFSET_M + 0.05:  # the target is under the camera's mast
        note = f"{name} is where the robot stands, so the camera looks ahead."
        return Aim(f"toward {name}", _wrap(heading), TILT_DEG, name, note)
    yaw = math.atan2(dy, dx)
    eye_x, eye_y = robot.x + LENS_OFFSET_M * math.cos(yaw), robot.y + LENS_OFFSET_M * math.sin(yaw)
    tilt = math.degrees(math.atan2(target[2] - MOUNT_HEIGHT_M, math.hypot(target[0] - eye_x, target[1] - eye_y)))
    tilt = min(max(tilt, TILT_RANGE[0]), TILT_RANGE[1])
    return Aim(f"toward {name}", _wrap(math.degrees(yaw)), round(tilt, 1), name)


#: The colour of pixels where the camera sees nothing (TinyRenderer leaves them white).
BACKGROUND = (206, 214, 224)


def capture(
    world: World, direction: str = "ahead", *, width: int = WIDTH, height: int = HEIGHT, scale: float | None = None
) -> CameraView:
    """Render the camera's view for `direction` (see `aim`) at `width` x `height` pixels, drawn at
    `scale` of each side (default `raster.RENDER_SCALE`; 1 draws every pixel) and scaled up."""
    if not (16 <= width <= MAX_SIDE and 16 <= height <= MAX_SIDE):
        raise ValueError(f"the image must be 16 to {MAX_SIDE} pixels on each side, not {width}x{height}")
    pointing = aim(world, direction)
    robot, client = world.sim.robot, world.sim.client
    yaw, tilt = math.radians(pointing.heading_deg), math.radians(pointing.tilt_deg)
    eye = (robot.x + LENS_OFFSET_M * math.cos(yaw), robot.y + LENS_OFFSET_M * math.sin(yaw), MOUNT_HEIGHT_M)
    forward = (math.cos(tilt) * math.cos(yaw), math.cos(tilt) * math.sin(yaw), math.sin(tilt))
    view = client.computeViewMatrix(eye, [e + f for e, f in zip(eye, forward, strict=True)], [0, 0, 1])
    projection = client.computeProjectionMatrixFOV(FOV_DEG, width / height, NEAR_M, FAR_M)
    w, h = raster.render_size(width, scale), raster.render_size(height, scale)
    with raster.arm_hidden_unless_seen(client, robot.arm, view, projection):
        # shadow=0 every time: TinyRenderer keeps the last call's shadow setting; shadows triple the time.
        _, _, rgba, depth, seg = client.getCameraImage(
            w, h, view, projection, renderer=pybullet.ER_TINY_RENDERER, shadow=0
        )
    small = np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)[:, :, :3].copy()
    small_segmentation = np.asarray(seg, dtype=np.int32).reshape(h, w)
    small[small_segmentation < 0] = BACKGROUND  # nothing there (above the walls): a ceiling, not blank paper
    rgb = raster.bilinear(small, height, width)
    rows, cols = raster.nearest(h, height), raster.nearest(w, width)
    segmentation = np.ascontiguousarray(small_segmentation[rows][:, cols])
    _legible(rgb, segmentation)  # at the output's size: outlines one pixel wide, not smeared by scaling
    buffer = np.asarray(depth, dtype=np.float32).reshape(h, w)[rows][:, cols]
    metres = (FAR_M * NEAR_M / (FAR_M - (FAR_M - NEAR_M) * buffer)).astype(np.float32)
    return CameraView(
        aim=pointing,
        rgb=np.ascontiguousarray(rgb),
        segmentation=segmentation,
        depth_m=metres,
        eye=eye,
        view_matrix=tuple(view),
        projection_matrix=tuple(projection),
    )


def render_camera(world: World, *, direction: str = "ahead", width: int = WIDTH, height: int = HEIGHT) -> bytes:
    """PNG bytes of the robot camera's view (see `capture`)."""
    return encode_png(capture(world, direction, width=width, height=height).rgb)


def encode_png(rgb: Image, *, level: int = 3) -> bytes:
    """An 8-bit RGB PNG of `rgb` (height x width x 3), with numpy and zlib only. Each row is stored
    with PNG's "Sub" filter (the difference to the pixel on its left), which flat-shaded renders
    compress well with. zlib's level 3 takes about half of level 6's time on a camera frame for about
    a fifth more bytes (a few kilobytes: docs/figures.md, Camera)."""
    height, width, channels = rgb.shape
    if channels != 3:
        raise ValueError(f"expected an RGB image, got {channels} channels")
    sub = rgb.astype(np.int16)
    sub[:, 1:] -= rgb[:, :-1]
    rows = np.empty((height, 1 + width * 3), dtype=np.uint8)
    rows[:, 0] = 1  # filter type Sub
    rows[:, 1:] = (sub & 0xFF).astype(np.uint8).reshape(height, width * 3)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"".join(
        [
            b"\x89PNG\r\n\x1a\n",
            _chunk(b"IHDR", header),
            _chunk(b"IDAT", zlib.compress(rows.tobytes(), level)),
            _chunk(b"IEND", b""),
        ]
    )


def caption(world: World, view: CameraView) -> Caption:
    """What the frame shows, from ground truth: the objects and furniture with at least `MIN_PIXELS`
    pixels in the segmentation, and the locations whose floor point is in the frame and not hidden."""
    ids, counts = np.unique(view.segmentation, return_counts=True)
    seen = {int(i) for i, n in zip(ids, counts, strict=True) if i >= 0 and n >= MIN_PIXELS}
    sim = world.sim
    objects = [_seen_object(world, view, name) for name, body in sim.objects.items() if body.body in seen]
    objects.sort(key=lambda o: o.distance_m)
    furniture = list(
        dict.fromkeys(
            key.split("/")[0].replace("_", " ") for key, body in sim.parts.items() if key != "floor" and body in seen
        )
    )
    locations = [name for name, (x, y) in world.map.points.items() if _floor_point_visible(view, x, y)]
    holding = world.holding
    parts = [f"{o.name} ({o.where}, {o.distance_m:.1f} m {o.side})" for o in objects]
    text = f"Looking {view.aim.direction} from {world.robot_location()}: "
    text += ", ".join(parts) if parts else "no objects"
    if furniture:
        text += f"; furniture: {', '.join(furniture)}"
    if locations:
        text += f"; locations in view: {', '.join(locations)}"
    text += f". Holding {'the ' + holding if holding else 'nothing'}."
    return Caption(text=text, objects=objects, furniture=furniture, locations=locations)


# --- helpers ---------------------------------------------------------------------------------------

#: Surfaces darker than this (0-255 luma) are lifted: flat-shaded, a black TV a step away would
#: fill half the frame with pure black, which reads as a broken picture rather than a screen.
DARK_LUMA = 40


def _legible(rgb: Image, segmentation: npt.NDArray[np.int32]) -> None:
    """In place: lift near-black surfaces to a dark grey, and draw each body's outline (a line where
    the body seen changes: lighter on dark pixels, darker on light ones), so that a dark object close
    to the lens shows as an object with edges."""
    luma = rgb.astype(np.int32) @ np.array([77, 150, 29], dtype=np.int32) >> 8
    dark = luma < DARK_LUMA
    rgb[dark] = rgb[dark] // 2 + DARK_LUMA
    edge = np.zeros(segmentation.shape, dtype=bool)
    edge[:, 1:] |= segmentation[:, 1:] != segmentation[:, :-1]
    edge[1:, :] |= segmentation[1:, :] != segmentation[:-1, :]
    lift = edge & dark
    rgb[lift] = np.minimum(rgb[lift].astype(np.int16) + 70, 255).astype(np.uint8)
    shade = edge & ~dark
    rgb[shade] = (rgb[shade].astype(np.uint16) * 3 // 4).astype(np.uint8)


def _wrap(degrees: float) -> float:
    """An angle in (-180, 180], rounded to a tenth of a degree."""
    wrapped = (degrees + 180.0) % 360.0 - 180.0
    return round(180.0 if wrapped == -180.0 else wrapped, 1)


def _location_target(world: World, location: str) -> tuple[float, float, float]:
    """What to look at for a location: the middle of its place positions, else of the furniture
    standing there, else its point on the map (half a metre up)."""
    positions = [p for p in world.sim.positions.values() if p.spec.location == location]
    if positions:
        n = len(positions)
        return (
            sum(p.spec.center[0] for p in positions) / n,
            sum(p.spec.center[1] for p in positions) / n,
            sum(p.surface_z for p in positions) / n,
        )
    furnished = [name for name, where in world.furniture_locations().items() if where == location]
    parts = [part for f in world.scene.furniture if f.name in furnished for part in f.parts]
    if parts:
        n = len(parts)
        return tuple(sum(p.center[i] for p in parts) / n for i in range(3))  # type: ignore[return-value]
    x, y = world.map.points[location]
    return (x, y, 0.5)


def _project(view: CameraView, point: tuple[float, float, float]) -> tuple[int, int, float] | None:
    """The pixel (column, row) a world point falls on and its distance along the view axis, or None
    when it is outside the frame or behind the camera."""
    v = np.asarray(view.view_matrix, dtype=np.float64).reshape(4, 4).T  # PyBullet's matrices are column-major
    p = np.asarray(view.projection_matrix, dtype=np.float64).reshape(4, 4).T
    camera = v @ np.array([*point, 1.0])
    clip = p @ camera
    if clip[3] <= 0:
        return None
    ndc_x, ndc_y = clip[0] / clip[3], clip[1] / clip[3]
    if not (-1 <= ndc_x <= 1 and -1 <= ndc_y <= 1):
        return None
    col = min(int((ndc_x + 1) / 2 * view.width), view.width - 1)
    row = min(int((1 - ndc_y) / 2 * view.height), view.height - 1)
    return col, row, float(-camera[2])


def _floor_point_visible(view: CameraView, x: float, y: float) -> bool:
    """A location counts as in view when its point, 5 cm above the floor, is in the frame and nothing
    nearer than it (by more than 0.3 m) covers that pixel."""
    hit = _project(view, (x, y, 0.05))
    if hit is None:
        return False
    col, row, distance = hit
    return bool(view.depth_m[row, col] >= distance - 0.3)


def _seen_object(world: World, view: CameraView, name: str) -> SeenObject:
    placement = truth.placement(world.sim, name)
    x, y, z = placement.xyz
    ex, ey, _ = view.eye
    bearing = _wrap(math.degrees(math.atan2(y - ey, x - ex)) - view.aim.heading_deg)
    side = "ahead" if abs(bearing) <= 10 else ("to the left" if bearing > 0 else "to the right")
    if placement.state == "held":
        where = "in the robot's hand"
    elif placement.state == "on_position":
        where = f"on {placement.location} {placement.position}"
    elif placement.location is not None:
        where = f"near {placement.location}"
    else:
        where = f"in the {placement.room}" if placement.room else "somewhere"
    distance = math.dist((x, y, z), view.eye)
    return SeenObject(name=name, where=where, distance_m=round(distance, 2), bearing_deg=bearing, side=side)


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


__all__ = [
    "DIRECTIONS",
    "HEIGHT",
    "WIDTH",
    "Aim",
    "CameraView",
    "aim",
    "caption",
    "capture",
    "encode_png",
    "render_camera",
]
