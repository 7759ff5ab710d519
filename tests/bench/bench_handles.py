"""Robot handles (SEP-2567), as figures:

- `look_around` p50 over HTTP from the SDK's default client (sessionless MCP 2026-07-28) on one
  robot, passing its robot handle as `robot_id`; with `ROBOCOG_BENCH_AGAINST=/its/.venv/bin` (the
  previous release, which knew no `robot_id`), that release's server too, its id sent back in
  `_meta["robocog/driver"]`, in alternating rounds;
- placement behind the router (`--robots 8 --processes 2`): eight sessionless clients each mint a
  handle (an id-less `look_around`) and present it; how many handles each process got.

`make bench` runs it with the others; `python tests/bench/bench_handles.py` alone.
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import anyio
from mcp import Client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from robocog.shared.protocol import DRIVER_META_KEY
from tests.helpers import http_server_process

CALLS = 300
ROUNDS = 5


async def _look_p50(url: str) -> float:
    """look_around p50 (ms) for one client that holds a handle: as `robot_id` where the server
    declares it, else (an older release) in `_meta`, as that release's clients sent it."""
    async with Client(url) as client:
        tools = {t.name: t for t in (await client.list_tools()).tools}
        declared = "robot_id" in tools["look_around"].input_schema.get("properties", {})
        first = await client.call_tool("move_to", {"location": "Front Door"})  # takes the robot
        handle = (first.structured_content or {}).get("robot_id") or (first.meta or {}).get(DRIVER_META_KEY)
        assert handle, first
        arguments: dict[str, Any] = {"robot_id": handle} if declared else {}
        meta: Any = None if declared else {DRIVER_META_KEY: handle}
        await client.call_tool("move_to", {"location": "Front Door", **arguments}, meta=meta)  # presented: it holds
        times = []
        for _ in range(CALLS):
            start = time.perf_counter()
            result = await client.call_tool("look_around", arguments, meta=meta)
            times.append(1000 * (time.perf_counter() - start))
            assert not result.is_error
    return round(statistics.median(times), 3)


def _with_server(command: list[str] | None) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        log, data = Path(tmp) / "server.log", str(Path(tmp) / "m")
        with http_server_process(log, "--data-dir", data, command=command) as (url, _):
            return anyio.run(_look_p50, url)


def look_around() -> dict[str, Any]:
    against = os.environ.get("ROBOCOG_BENCH_AGAINST")
    ours: list[float] = []
    theirs: list[float] = []
    for _ in range(ROUNDS if against else 1):
        ours.append(_with_server(None))
        if against:
            theirs.append(_with_server([str(Path(against) / "robocog-server")]))
    figures: dict[str, Any] = {"handles.look_around_with_handle.p50_ms": round(statistics.median(ours), 3)}
    if against:
        figures["handles.against.look_around_with_driver_id.p50_ms"] = round(statistics.median(theirs), 3)
        figures["handles.rounds"] = ROUNDS
    return figures


async def _place(url: str) -> list[str]:
    origins = []
    async with Client(url) as client:
        for _ in range(8):
            minted = await client.call_tool("look_around", {})
            handle = (minted.structured_content or {})["robot_id"]
            presented = await client.call_tool("move_to", {"location": "Kitchen Door", "robot_id": handle})
            assert not presented.is_error, presented.content
            origins.append(str(handle).split(".", 1)[0])
    return origins


def router() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        args = ("--robots", "8", "--processes", "2", "--data-dir", str(Path(tmp) / "m"))
        with http_server_process(Path(tmp) / "router.log", *args, timeout_s=120) as (url, _):
            origins = anyio.run(_place, url)
    return {"handles.router_8_handles_per_process": [origins.count(str(i)) for i in range(2)]}


def run() -> dict[str, Any]:
    return look_around() | router()


if __name__ == "__main__":
    print(json.dumps(run()))
