"""Benchmark of the robot's camera (not a pytest module).

Run: ``.venv/bin/python tests/bench/bench_camera.py``. Target (reported, not asserted): the camera's
frame and PNG at 320x240 p95 <= 30 ms. Measured at five places and four directions: the frame
alone, the frame plus the PNG (`render_camera`), the caption, and the whole `look` call through an
in-memory MCP client (JSON, base64, the SDK). Each view is also rendered the previous release's way,
every pixel and the arm drawn, right after the new one: the "full" figures are the before of the
same moment, so that the machine's drift does not pass for a speed-up. A bare physics step is timed
too, as this machine's speed of the moment (it drifts by up to 1.7x over an hour), and the frame's CPU
time beside its wall time (the renderer is single-threaded: on a busy machine the wall time includes
waiting for a core).
"""

from __future__ import annotations

import contextlib
import json
import statistics
import time
from pathlib import Path
from typing import Any

import anyio
from mcp import Client

from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.server.world import camera, raster
from robocog.server.world.world import World

#: Where the robot stands and where it looks: the views a model gets in T1.
PLACES = ["Front Door", "Hallway Area Door", "Kitchen Area Left", "Kitchen Table", "Living Room"]
DIRECTIONS = ["ahead", "left", "right", "behind"]
ROUNDS = 3
CALLS = 40
TARGET_RENDER_MS = 30.0


def _ms(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return round(ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))] * 1000, 2)


def _previous(world: World, direction: str) -> tuple[float, float]:
    """The wall time of a frame rendered the previous release's way (every pixel, the arm drawn even
    out of the frame), and of it and its PNG (zlib's level 6)."""
    hide = raster.arm_hidden_unless_seen
    raster.arm_hidden_unless_seen = lambda *_: contextlib.nullcontext()  # type: ignore[assignment]
    try:
        t0 = time.perf_counter()
        view = camera.capture(world, direction, scale=1.0)
        t1 = time.perf_counter()
        camera.encode_png(view.rgb, level=6)
        return t1 - t0, time.perf_counter() - t0
    finally:
        raster.arm_hidden_unless_seen = hide


def _world_figures() -> dict[str, Any]:
    frame: list[float] = []
    frame_cpu: list[float] = []
    whole: list[float] = []
    captions: list[float] = []
    sizes: list[int] = []
    pngs: list[float] = []
    pngs_level6: list[float] = []
    sizes_level6: list[int] = []
    full: list[float] = []
    full_whole: list[float] = []
    with World() as world:
        start = time.perf_counter()
        for _ in range(200):
            world.sim.step()
        bare_step_us = (time.perf_counter() - start) / 200 * 1e6
        here = world.robot_location()
        for place in PLACES:
            path = world.map.shortest_path(here, place)
            assert path is not None
            world.drive(path)
            here = place
            camera.capture(world, "ahead")  # the first frame of a place warms nothing up, but be fair
            for _ in range(ROUNDS):
                for direction in DIRECTIONS:
                    t0, c0 = time.perf_counter(), time.thread_time()
                    view = camera.capture(world, direction)
                    t1, c1 = time.perf_counter(), time.thread_time()
                    png = camera.encode_png(view.rgb)
                    t2 = time.perf_counter()
                    camera.caption(world, view)
                    t3 = time.perf_counter()
                    frame.append(t1 - t0)
                    frame_cpu.append(c1 - c0)
                    whole.append(t2 - t0)
                    captions.append(t3 - t2)
                    sizes.append(len(png))
                    pngs.append(t2 - t1)
                    t4 = time.perf_counter()
                    sizes_level6.append(len(camera.encode_png(view.rgb, level=6)))  # the previous release's
                    pngs_level6.append(time.perf_counter() - t4)
                    before, before_whole = _previous(world, direction)
                    full.append(before)
                    full_whole.append(before_whole)
    return {
        "camera.frames": len(frame),
        "camera.render_p50_ms": _ms(frame, 0.5),
        "camera.render_p95_ms": _ms(frame, 0.95),
        # The renderer's own CPU time: what the wall time would be on an idle core.
        "camera.render_cpu_p50_ms": _ms(frame_cpu, 0.5),
        "camera.render_png_p50_ms": _ms(whole, 0.5),
        "camera.render_png_p95_ms": _ms(whole, 0.95),
        "camera.caption_p50_ms": _ms(captions, 0.5),
        "camera.png_bytes_median": int(statistics.median(sizes)),
        "camera.png_p50_ms": _ms(pngs, 0.5),
        # The same frames' PNG at zlib's level 6, as the previous release compressed them.
        "camera.png_level6_p50_ms": _ms(pngs_level6, 0.5),
        "camera.png_level6_bytes_median": int(statistics.median(sizes_level6)),
        "camera.render_target_ms": TARGET_RENDER_MS,
        "camera.render_target_met": _ms(whole, 0.95) <= TARGET_RENDER_MS,
        "camera.render_scale": raster.RENDER_SCALE,
        # The same views the previous release's way, each right after the new frame.
        "camera.render_full_p50_ms": _ms(full, 0.5),
        "camera.render_full_p95_ms": _ms(full, 0.95),
        "camera.render_png_full_p50_ms": _ms(full_whole, 0.5),
        "camera.render_png_full_p95_ms": _ms(full_whole, 0.95),
        "camera.bare_step_us": round(bare_step_us, 2),
    }


async def _look_calls(tmp: str) -> dict[str, Any]:
    server = build_server(SessionConfig(data_dir=Path(tmp) / "memory"))
    async with Client(server, raise_exceptions=True) as client:
        await client.call_tool("look", {})  # the session is built in the background: wait for it
        plain: list[float] = []
        captioned: list[float] = []
        for i in range(CALLS):
            direction = DIRECTIONS[i % len(DIRECTIONS)]
            t0 = time.perf_counter()
            result = await client.call_tool("look", {"direction": direction})
            t1 = time.perf_counter()
            await client.call_tool("look", {"direction": direction, "caption": True})
            t2 = time.perf_counter()
            assert not result.is_error and len(result.content) == 2
            plain.append(t1 - t0)
            captioned.append(t2 - t1)
    return {
        "camera.look_mcp_p50_ms": _ms(plain, 0.5),
        "camera.look_mcp_p95_ms": _ms(plain, 0.95),
        "camera.look_caption_mcp_p50_ms": _ms(captioned, 0.5),
    }


def run() -> dict[str, Any]:
    """The camera's figures: a flat dict of rounded numbers (and whether the target is met)."""
    import tempfile

    out = _world_figures()
    with tempfile.TemporaryDirectory() as tmp:
        out.update(anyio.run(_look_calls, tmp))
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
