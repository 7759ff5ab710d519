"""What keeps the camera's frame cheap: TinyRenderer's time is its pixel fill plus the vertices of
every visual mesh in the world, seen or not, so the camera renders fewer pixels and scales them up,
and hides the robot's arm (15,000 triangles, 2.3 ms of every frame) when it is out of the frame.

    w, h = render_size(320), render_size(240)          # 240 x 180
    with arm_hidden_unless_seen(client, arm, view, projection):
        ... client.getCameraImage(w, h, view, projection, ...) ...
    rgb = bilinear(small, 240, 320)                    # colours: interpolated
    ids = small_ids[nearest(h, 240)][:, nearest(w, 320)]  # body ids and depth: never blended
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np
import numpy.typing as npt
from pybullet_utils.bullet_client import BulletClient

#: The renderer draws each side at this fraction of the image's, then the frame is scaled up. At 3/4
#: the picture looks like the full-size one (furniture, a mug three metres away, the TV); at 1/2 that
#: mug is a smudge and edges step visibly.
RENDER_SCALE = 0.75

Image = npt.NDArray[np.uint8]


def render_size(side: int, scale: float | None = None) -> int:
    """How many pixels the renderer draws for an image side of `side` (at least 16)."""
    return max(16, round(side * (RENDER_SCALE if scale is None else scale)))


def nearest(n: int, size: int) -> npt.NDArray[np.intp]:
    """For each of `size` output pixels along a side, the one of `n` rendered pixels under its centre."""
    return np.minimum(((np.arange(size) + 0.5) * (n / size)).astype(np.intp), n - 1)


def bilinear(small: Image, height: int, width: int) -> Image:
    """`small` (h x w x 3) scaled to `height` x `width` by bilinear interpolation between pixel centres,
    in 16-bit integers with weights in sixteenths (exact for 3/4; about a millisecond at 320x240)."""
    h, w = small.shape[:2]
    if (h, w) == (height, width):
        return small
    r0, r1, fy = _axis(h, height)
    c0, c1, fx = _axis(w, width)
    pixels = small.astype(np.uint16)
    rows = pixels[r0] * (16 - fy)[:, None, None] + pixels[r1] * fy[:, None, None]  # at most 255 x 16
    out = rows[:, c0] * (16 - fx)[None, :, None] + rows[:, c1] * fx[None, :, None]  # at most 255 x 256
    return np.right_shift(out + 128, 8).astype(np.uint8)


@contextmanager
def arm_hidden_unless_seen(
    client: BulletClient, arm: int, view: Sequence[float], projection: Sequence[float]
) -> Iterator[None]:
    """Within the block, the arm's links are transparent (TinyRenderer then skips them) when the arm's
    bounding box is wholly outside the view frustum: a frame without the arm looks the same and
    costs 2.3 ms less. Their colours are put back after, whatever happens."""
    links = range(-1, client.getNumJoints(arm))
    boxes = np.array([client.getAABB(arm, link) for link in links], dtype=np.float64)  # links x 2 x 3
    low, high = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
    if not _outside(low, high, view, projection):
        yield
        return
    shapes = client.getVisualShapeData(arm)
    for shape in shapes:
        client.changeVisualShape(arm, shape[1], rgbaColor=[*shape[7][:3], 0.0])
    try:
        yield
    finally:
        for shape in shapes:
            client.changeVisualShape(arm, shape[1], rgbaColor=list(shape[7]))


def _axis(n: int, size: int) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.uint16]]:
    """For `size` output pixels from `n`: the rendered pixel at or before each centre, the one after,
    and the weight of the one after (sixteenths)."""
    at = np.clip((np.arange(size) + 0.5) * (n / size) - 0.5, 0, n - 1)
    low = np.floor(at).astype(np.intp)
    return low, np.minimum(low + 1, n - 1), np.round((at - low) * 16).astype(np.uint16)


def _outside(
    low: npt.NDArray[np.float64], high: npt.NDArray[np.float64], view: Sequence[float], projection: Sequence[float]
) -> bool:
    """Whether the box from `low` to `high` is wholly on the outer side of one of the frustum's planes
    (a conservative test: a box near a corner of the frustum may count as inside)."""
    xs, ys, zs = zip(low, high, strict=True)
    corners = np.array([[x, y, z, 1.0] for x in xs for y in ys for z in zs])
    v = np.asarray(view, dtype=np.float64).reshape(4, 4).T  # PyBullet's matrices are column-major
    p = np.asarray(projection, dtype=np.float64).reshape(4, 4).T
    clip = corners @ (p @ v).T  # 8 x 4: x, y, z, w
    x, y, z, w = clip.T
    return bool((x > w).all() or (x < -w).all() or (y > w).all() or (y < -w).all() or (z < -w).all() or (z > w).all())


__all__ = ["RENDER_SCALE", "arm_hidden_unless_seen", "bilinear", "nearest", "render_size"]
