"""`make soak`: T1 episodes with memory against one real HTTP server, on both MCP protocol
generations and with a plain client, printing the server's RSS per 100 episodes (bounded in time).

Each episode is what a harness does with memory: reset_world, begin_task("T1"), search_memory, the
12 actions of T1, end_task, check_task. The session generation is an MCP session (the initialize
handshake, protocol 2025-11-25); the sessionless one is the SDK's default `mcp.Client(url)`
(protocol 2026-07-28), which sends back the driver id the server issued it (in `_meta`, the alias
robocog's own client uses); the plain one is that client as anyone would use it, which never sends
a handle back (the anonymous driver of a one-robot server). Each generation gets its own fresh
server. Growth per 100 episodes is the slope of a least-squares line through the RSS samples after
the warm-up (the first 100 episodes).

    make soak                                   # SOAK_EPISODES=1000 per generation, SOAK_MINUTES=30 in all
    .venv/bin/python tests/bench/soak.py --episodes 300 --minutes 10
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import anyio
from mcp import Client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from robocog.shared.protocol import DRIVER_META_KEY
from tests.helpers import T1_SEQUENCE, action_args, free_port, server_command, server_env

WARM_UP = 100
EVERY = 100


def rss_mb(pid: int) -> float:
    return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * 4096 / 1e6


def slope_per_100(points: list[tuple[int, float]]) -> float | None:
    """MB per 100 episodes: the least-squares slope through (episodes, RSS) after the warm-up."""
    kept = [(x, y) for x, y in points if x >= WARM_UP]
    if len(kept) < 2:
        return None
    mx = sum(x for x, _ in kept) / len(kept)
    my = sum(y for _, y in kept) / len(kept)
    var = sum((x - mx) ** 2 for x, _ in kept)
    return round(100 * sum((x - mx) * (y - my) for x, y in kept) / var, 2) if var else None


async def episodes(url: str, pid: int, generation: str, n: int, deadline: float, light: bool) -> dict[str, Any]:
    from mcp.client.streamable_http import streamable_http_client

    target: Any = streamable_http_client(url) if generation == "session" else url
    mode = "legacy" if generation == "session" else "auto"
    points: list[tuple[int, float]] = [(0, rss_mb(pid))]
    meta: dict[str, Any] | None = None
    started = time.monotonic()
    done = successes = 0
    async with Client(target, mode=mode) as client:

        async def call(tool: str, **arguments: Any) -> Any:
            nonlocal meta
            result = await client.call_tool(tool, arguments, meta=meta)  # type: ignore[arg-type]
            issued = (result.meta or {}).get(DRIVER_META_KEY)
            if issued is not None and generation == "sessionless":  # the plain client never sends it back
                meta = {DRIVER_META_KEY: issued}
            if result.is_error and tool not in ("grab", "place", "move_to"):
                raise RuntimeError(f"{tool}: {result.content}")
            return result.structured_content

        for episode in range(1, n + 1):
            await call("reset_world", memory_namespace="soak")
            await call("begin_task", task_id="T1")
            await call("search_memory", query="Put away all the items into the shelf.")
            for action in (("look_around",),) if light else T1_SEQUENCE:
                await call(action[0], **action_args(action))
            await call("end_task", status="success", description="Put away all the items", summary=f"episode {episode}")
            verdict = await call("check_task", task_id="T1")
            assert light or verdict["success"], verdict
            successes += bool(verdict["success"])
            done = episode
            if episode % EVERY == 0:
                points.append((episode, round(rss_mb(pid), 1)))
                print(f"soak {generation}: {episode} episodes, RSS {points[-1][1]} MB", file=sys.stderr, flush=True)
            if time.monotonic() > deadline:
                break
    return {
        "episodes": done,
        "true_successes": successes,
        "episodes_per_min": round(60 * done / (time.monotonic() - started), 1),
        "rss_mb_per_100": points,
        "growth_mb_per_100_after_warm_up": slope_per_100(points),
    }


def serve(tmp: Path) -> tuple[str, subprocess.Popen[bytes]]:
    port = free_port()
    log = (tmp / "server.log").open("wb")
    args = ["--transport", "http", "--port", str(port), "--profile", "eval", "--data-dir", str(tmp / "memory")]
    proc = subprocess.Popen([*server_command(), *args], stdout=log, stderr=subprocess.STDOUT, env=server_env())
    deadline = time.monotonic() + 90
    while True:
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError("the server did not start: " + (tmp / "server.log").read_text(errors="replace"))
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return f"http://127.0.0.1:{port}/mcp", proc
        time.sleep(0.1)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=int(os.environ.get("SOAK_EPISODES", "1000")))
    parser.add_argument("--minutes", type=float, default=float(os.environ.get("SOAK_MINUTES", "30")))
    parser.add_argument("--generations", default="session,sessionless,plain")
    parser.add_argument("--record", action="store_true", help="record the figures in docs/figures.json")
    parser.add_argument(
        "--light",
        action="store_true",
        help="episodes that use the memory but do not move (look_around instead of T1's 12 actions): "
        "the calls that grew, at about ten times the pace",
    )
    args = parser.parse_args()
    generations = [g for g in args.generations.split(",") if g]
    figures: dict[str, Any] = {}
    for i, generation in enumerate(generations):
        # each generation gets an equal share of the time left
        share = (args.minutes * 60 - sum(f.get("wall_s", 0) for f in figures.values())) / (len(generations) - i)
        with tempfile.TemporaryDirectory(prefix="rc-soak-") as tmp:
            url, proc = serve(Path(tmp))
            try:
                started = time.monotonic()
                result = anyio.run(episodes, url, proc.pid, generation, args.episodes, started + share, args.light)
                figures[generation] = result | {"wall_s": round(time.monotonic() - started, 1)}
            finally:
                proc.terminate()
                proc.wait(timeout=30)
    print(json.dumps(figures))
    if args.record:
        from tests.bench.run import RECORD, record

        kind = "light" if args.light else "t1"
        record({f"soak.{kind}.{g}.{k}": v for g, f in figures.items() for k, v in f.items()}, RECORD)
    return 0


if __name__ == "__main__":
    sys.exit(main())
