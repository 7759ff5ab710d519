"""Server figures: cold start over stdio, an in-memory read-only round trip, T1 as MCP calls over stdio;
with `ROBOCOG_BENCH_AGAINST=/path/to/other/.venv/bin`, the same from that install too, in alternating
rounds (`run`)."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import anyio
from mcp import Client
from mcp.client.stdio import StdioServerParameters, stdio_client

from robocog.server.app import build_server
from robocog.server.config import SessionConfig

try:
    from robocog.server.world.paper import T1_SEQUENCE
except ImportError:  # a release before issue 49 (`ROBOCOG_BENCH_AGAINST` runs this file under its install)
    from robocog.shared.paper import T1_SEQUENCE  # type: ignore[import-not-found,no-redef]

COLD_STARTS = 5
ROUND_TRIPS = 500
TARGETS = {
    "server.target_cold_start_s": 2.5,
    "server.target_round_trip_p50_ms": 1.0,
    "server.target_t1_over_stdio_s": 0.4,
}
#: Alternating rounds of both installs when another is measured too (`run`).
AGAINST_ROUNDS = 5
T1_RUNS = 7


def _server() -> list[str]:
    script = Path(sys.executable).parent / "robocog-server"
    return [str(script)] if script.exists() else [sys.executable, "-m", "robocog.server.cli"]


def _args(action: tuple[str, ...]) -> dict[str, str]:
    name, *rest = action
    keys = {"look_around": [], "move_to": ["location"], "grab": ["object"], "place": ["location", "position"]}[name]
    return dict(zip(keys, rest, strict=True))


async def _cold_start(data: str) -> float:
    command, *args = _server()
    params = StdioServerParameters(command=command, args=[*args, "--data-dir", data])
    with open("/dev/null", "w") as devnull:
        start = time.perf_counter()
        async with Client(stdio_client(params, errlog=devnull)) as client:
            await client.list_tools()
            return time.perf_counter() - start


async def _t1_over_stdio(data: str) -> list[float]:
    command, *args = _server()
    params = StdioServerParameters(command=command, args=[*args, "--profile", "eval", "--data-dir", data])
    times = []
    with open("/dev/null", "w") as devnull:
        async with Client(stdio_client(params, errlog=devnull)) as client:
            await client.call_tool("look_around", {})  # waits for the world
            for _ in range(T1_RUNS):
                await client.call_tool("reset_world", {})
                start = time.perf_counter()
                for action in T1_SEQUENCE:
                    result = await client.call_tool(action[0], _args(action))
                    assert not result.is_error, result.content
                times.append(time.perf_counter() - start)
            check = await client.call_tool("check_task", {"task_id": "T1"})
            assert check.structured_content and check.structured_content["success"]
    return times


async def _round_trips(data: str) -> list[float]:
    server = build_server(SessionConfig(data_dir=Path(data)))
    times = []
    async with Client(server) as client:
        await client.call_tool("view_scratchpad", {})
        for _ in range(ROUND_TRIPS):
            start = time.perf_counter()
            await client.call_tool("view_scratchpad", {})
            times.append(time.perf_counter() - start)
    return times


def _p(values: list[float], q: float) -> float:
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))]


def _measured_by(python: Path) -> dict[str, float]:
    """This bench's own figures (`measure`), measured by `python` (an install's) in a process of its own."""
    env = {**os.environ, "ROBOCOG_BENCH_AGAINST": ""}
    done = subprocess.run([str(python), __file__], capture_output=True, text=True, timeout=900, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{python}: bench_server failed: {done.stderr[-800:]}")
    start = 0 if done.stdout.startswith("{") else done.stdout.index("\n{") + 1  # after PyBullet's banner
    return {k: v for k, v in json.loads(done.stdout[start:]).items() if "target" not in k}


def run() -> dict[str, float]:
    """This install's figures; with `ROBOCOG_BENCH_AGAINST=/its/.venv/bin` (the previous release), both
    installs' in `AGAINST_ROUNDS` alternating rounds, each figure the median of its rounds (this
    machine's speed moves a figure measured once by more than the difference), the other's under
    `server.against.`."""
    bin_dir = os.environ.get("ROBOCOG_BENCH_AGAINST")
    if not bin_dir:
        return measure()
    rounds: dict[str, list[dict[str, float]]] = {"server.": [], "server.against.": []}
    for _ in range(AGAINST_ROUNDS):
        rounds["server."].append(_measured_by(Path(sys.executable)))
        rounds["server.against."].append(_measured_by(Path(bin_dir) / "python"))
    out = dict(TARGETS)
    for prefix, runs in rounds.items():
        for key in runs[0]:
            out[key.replace("server.", prefix, 1)] = round(statistics.median(r[key] for r in runs), 4)
    return out


def measure() -> dict[str, float]:
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        colds = [anyio.run(_cold_start, f"{tmp}/cold{i}") for i in range(COLD_STARTS)]
        out["server.cold_start_to_tools_list_s"] = round(statistics.median(colds), 3)
        out["server.cold_start_min_s"] = round(min(colds), 3)
        trips = anyio.run(_round_trips, f"{tmp}/mem")
        out["server.read_only_round_trip_p50_ms"] = round(_p(trips, 0.5) * 1e3, 3)
        out["server.read_only_round_trip_p95_ms"] = round(_p(trips, 0.95) * 1e3, 3)
        t1 = anyio.run(_t1_over_stdio, f"{tmp}/t1")
        out["server.t1_12_calls_over_stdio_s"] = round(statistics.median(t1), 4)
        out["server.t1_12_calls_over_stdio_min_s"] = round(min(t1), 4)
    return out | TARGETS


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
