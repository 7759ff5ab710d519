"""Trust under real clients, as figures (issue 24):

- `move_to` p50 with 0 and 300 live-viewer readers (`robocog-server --view`, stdio);
- a routed fleet (`--robots 4 --processes 2`): the time from `kill -9` of a fleet process to full
  capacity again (every robot drivable by a new session);
- a fleet's RSS growth over 200 memory namespaces (`reset_world(memory_namespace=...)` + `end_task`
  each, over HTTP), after a warm-up of 20.

`make bench` runs it with the others; `python tests/bench/bench_trust.py viewer,router,namespaces`
runs some.
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import anyio
from mcp import Client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import (
    fleet_processes,
    http_server_process,
    http_session,
    live_server,
    raw_call,
    raw_initialize,
    rss_mb,
)

MOVES = 40
ROUNDS = 5
READERS = int(os.environ.get("BENCH_VIEWER_READERS", "300"))


async def _move_p50(client: Client) -> float:
    times = []
    for i in range(MOVES):
        t0 = time.perf_counter()
        result = await client.call_tool("move_to", {"location": "Hallway Area Door" if i % 2 == 0 else "Front Door"})
        times.append(1000 * (time.perf_counter() - t0))
        assert not result.is_error
    return round(statistics.median(times), 1)


async def _viewer() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        async with live_server(Path(tmp) / "m") as (client, url):
            await client.call_tool("look_around", {})
            # alternated rounds: this machine's noise (another suite, other processes) hits both alike
            withouts, withs = [], []
            for _ in range(ROUNDS):
                withouts.append(await _move_p50(client))
                # the readers are another process (a browser's work is not the robot's client's)
                readers = subprocess.Popen(
                    [sys.executable, "-c", READERS_SCRIPT, url, str(READERS)], stdout=subprocess.PIPE, text=True
                )
                assert readers.stdout is not None
                opened = json.loads(readers.stdout.readline())
                withs.append(await _move_p50(client))
                readers.terminate()
                received = json.loads(readers.communicate(timeout=30)[0] or "0")
            without, with_readers = statistics.median(withouts), statistics.median(withs)
    return {
        "trust.move_to_p50_ms_0_readers": without,
        f"trust.move_to_p50_ms_{READERS}_readers": with_readers,
        "trust.move_to_slowdown_with_readers": round(with_readers / without, 2),
        "trust.move_to_p50_ms_rounds": {"0": withouts, str(READERS): withs},
        "trust.viewer_readers_admitted": opened.get("200", 0),
        "trust.viewer_readers_refused_503": opened.get("503", 0),
        "trust.viewer_bytes_streamed": received,
    }


#: Opens N event streams, prints how they were answered, reads until SIGTERM, prints the bytes read.
READERS_SCRIPT = """
import json, signal, sys, anyio, httpx
async def main(url, n):
    statuses, received = [], [0]
    limits = httpx.Limits(max_connections=None, max_keepalive_connections=0)
    async with httpx.AsyncClient(base_url=url, timeout=None, limits=limits) as http:
        async def reader():
            async with http.stream("GET", "api/events") as response:
                statuses.append(response.status_code)
                async for chunk in response.aiter_raw():
                    received[0] += len(chunk)
        async with anyio.create_task_group() as tg:
            for _ in range(n):
                tg.start_soon(reader)
            while len(statuses) < n:
                await anyio.sleep(0.05)
            print(json.dumps({str(s): statuses.count(s) for s in set(statuses)}), flush=True)
            with anyio.open_signal_receiver(signal.SIGTERM) as signals:
                async for _ in signals:
                    break
            tg.cancel_scope.cancel()
    print(received[0], flush=True)
anyio.run(main, sys.argv[1], int(sys.argv[2]))
"""


def _drive(url: str) -> bool:
    """A new session that makes a call: True when it got a robot."""
    answer = raw_initialize(url)
    if answer.status_code != 200:
        return False
    called = raw_call(url, answer.headers["mcp-session-id"], "look_around")
    return called.startswith("200 ") and '"isError":true' not in called.replace(" ", "")


def _router() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "router.log"
        args = ("--robots", "4", "--processes", "2", "--data-dir", str(Path(tmp) / "m"))
        with http_server_process(log, *args, timeout_s=600) as (url, proc):
            victim = fleet_processes(proc.pid)[0]
            os.kill(victim, signal.SIGKILL)
            killed = time.monotonic()
            while "died (signal 9)" not in log.read_text(errors="replace"):
                time.sleep(0.01)
            noticed = time.monotonic() - killed
            while "is back" not in log.read_text(errors="replace"):
                time.sleep(0.05)
            back = time.monotonic() - killed
            drivers = 0
            while drivers < 4:  # four new sessions all get robots: full capacity
                drivers += _drive(url)
            full = time.monotonic() - killed
            text = log.read_text(errors="replace")
    return {
        "trust.router_kill9_noticed_s": round(noticed, 2),
        "trust.router_kill9_process_back_s": round(back, 2),
        "trust.router_kill9_full_capacity_s": round(full, 2),
        "trust.router_log_lines_about_the_death": sum(1 for line in text.splitlines() if "fleet process" in line),
        "trust.router_tracebacks": text.count("Traceback"),
    }


async def _namespaces(open_namespaces: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        args = ["--robots", "2", "--profile", "eval", "--data-dir", str(Path(tmp) / "m")]
        args += ["--memory-namespaces", str(open_namespaces)]
        with http_server_process(Path(tmp) / "server.log", *args, timeout_s=600) as (url, proc):
            async with http_session(url) as client:
                base = 0.0
                for i in range(200):
                    if i == 20:
                        base = rss_mb(proc.pid)
                    await client.call_tool("reset_world", {"memory_namespace": f"unit-{i}"})
                    report = {"status": "success", "description": f"task {i}", "summary": "s"}
                    result = await client.call_tool("end_task", report)
                    assert not result.is_error
                grown = rss_mb(proc.pid) - base
    return {f"trust.rss_growth_mb_200_namespaces_open_{open_namespaces}": round(grown, 1)}


def run(only: str = "") -> dict[str, Any]:
    wanted = {w for w in only.split(",") if w}
    figures: dict[str, Any] = {}
    if not wanted or "viewer" in wanted:
        figures |= anyio.run(_viewer)
    if not wanted or "router" in wanted:
        figures |= _router()
    if not wanted or "namespaces" in wanted:
        figures |= anyio.run(_namespaces, 32)
    if "unbounded" in wanted:
        figures |= anyio.run(_namespaces, 100_000)
    return figures


if __name__ == "__main__":
    print(json.dumps(run(sys.argv[1] if len(sys.argv) > 1 else "")))
