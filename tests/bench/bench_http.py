"""HTTP access figures: what the bearer token costs a call, and what sessions cost and give back.

A real `robocog-server --transport http` process on a free loopback port:
- a read-only call (look_around) over one session, p50/p99, without and with a bearer token;
- sessions: RSS of the server before, with the cap (64) open, after 2,000 refused opens past the cap,
  and after every session was closed (DELETE), i.e. whether the memory comes back;
- connection reuse over event-stream answers: the same calls through the SDK's client as it comes (a
  plain httpx2 client) and through robocog's path for a server a user names
  (`agent.client.connection._http_transport`: the SDK as it comes, with the bearer token, its timeouts
  and idle connections kept through a model's turn), alternating in rounds on one server: the TCP
  connections each opened (counted at the event loop, where httpx opens them), the client's and the
  server's CPU per call, the wall time, and the connections opened by calls after a pause longer than
  httpx's and uvicorn's 5 s;
- one JSON body per answer: against a server started with `--json-response` (as the harness starts
  its fleets), the same calls' CPU and time through robocog's SDK path and through the lean client's
  channel a study's fleets use (`agent/client/json_http.py`), alternating in rounds.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import anyio
import httpx
import httpx2
from mcp import Client
from mcp.client.streamable_http import streamable_http_client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import free_port, server_command

CALLS = 300
REUSE_CALLS, REUSE_ROUNDS = 400, 8
#: Calls after an idle pause (a model's turn), and the pause.
IDLE_CALLS, IDLE_S = 3, 6.0
MAX_SESSIONS = 64
REFUSED = 2000
TOKEN = "bench-token-0123456789abcdef"
INITIALIZE = {
    "jsonrpc": "2.0",
    "id": 1,
    "method": "initialize",
    "params": {"protocolVersion": "2025-11-25", "capabilities": {}, "clientInfo": {"name": "bench", "version": "1"}},
}


def _start(data: str, *extra: str) -> tuple[subprocess.Popen[bytes], str]:
    command = server_command()
    port = free_port()
    proc = subprocess.Popen(
        [*command, "--transport", "http", "--port", str(port), "--data-dir", data, *extra],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "ANONYMIZED_TELEMETRY": "False"},
    )
    url = f"http://127.0.0.1:{port}/mcp"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            httpx.get(f"http://127.0.0.1:{port}/", timeout=0.5)
            return proc, url
        except httpx.TransportError:
            time.sleep(0.1)
    proc.kill()
    raise RuntimeError("the server did not start")


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


async def _round_trips(url: str, token: str | None) -> list[float]:
    headers = {"authorization": f"Bearer {token}"} if token else {}
    times = []
    async with (
        httpx2.AsyncClient(headers=headers) as http,
        Client(streamable_http_client(url, http_client=http), mode="legacy") as client,
    ):
        await client.call_tool("look_around", {})  # the world is built
        for _ in range(CALLS):
            start = time.perf_counter()
            await client.call_tool("look_around", {})
            times.append((time.perf_counter() - start) * 1000)
    return times


class _Connects:
    """Counts the TCP connections this process opens: httpcore opens them through the event loop's
    `create_connection` (anyio's TCP connect)."""

    def __init__(self) -> None:
        self.count = 0

    @contextlib.contextmanager
    def counting(self) -> Iterator[None]:
        real = asyncio.BaseEventLoop.create_connection

        async def counted(loop: asyncio.BaseEventLoop, *args: Any, **kwargs: Any) -> Any:
            self.count += 1
            return await real(loop, *args, **kwargs)

        asyncio.BaseEventLoop.create_connection = counted  # type: ignore[assignment, method-assign]
        try:
            yield
        finally:
            asyncio.BaseEventLoop.create_connection = real  # type: ignore[method-assign]


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


async def _reuse(url: str, pid: int) -> dict[str, object]:
    """The connections, CPU and time of REUSE_CALLS calls each way, in alternating rounds."""
    from robocog.agent.client.connection import _http_transport

    connects = _Connects()
    totals = {way: {"connections": 0, "client_cpu": 0.0, "server_cpu": 0.0, "wall": 0.0} for way in ("sdk", "robocog")}
    with connects.counting():
        async with (
            # The SDK's client as it comes, with robocog's timeouts (httpx's 5 s would end its GET stream).
            httpx2.AsyncClient(timeout=httpx2.Timeout(30.0, read=300.0)) as http,
            Client(streamable_http_client(url, http_client=http), mode="legacy") as sdk,
            Client(_http_transport(url, None), mode="legacy") as ours,
        ):
            await sdk.call_tool("look_around", {})
            await ours.call_tool("look_around", {})
            for _ in range(REUSE_ROUNDS):
                for way, client in (("sdk", sdk), ("robocog", ours)):
                    n, c0, s0, t0 = connects.count, time.process_time(), _cpu_s(pid), time.perf_counter()
                    for _ in range(REUSE_CALLS // REUSE_ROUNDS):
                        await client.call_tool("look_around", {})
                    total = totals[way]
                    total["wall"] += time.perf_counter() - t0
                    total["server_cpu"] += _cpu_s(pid) - s0
                    total["client_cpu"] += time.process_time() - c0
                    total["connections"] += connects.count - n
            idle = {"sdk": 0, "robocog": 0}
            for _ in range(IDLE_CALLS):  # a model's turn between two calls: longer than httpx's and uvicorn's 5 s
                await anyio.sleep(IDLE_S)
                for way, client in (("sdk", sdk), ("robocog", ours)):
                    n = connects.count
                    await client.call_tool("look_around", {})
                    idle[way] += connects.count - n
    figures: dict[str, object] = {}
    for way, total in totals.items():
        key = f"http.reuse.{way}"
        figures[f"{key}.connections_per_100_calls"] = round(total["connections"] / REUSE_CALLS * 100, 1)
        figures[f"{key}.client_cpu_ms_per_call"] = round(total["client_cpu"] / REUSE_CALLS * 1000, 2)
        figures[f"{key}.server_cpu_ms_per_call"] = round(total["server_cpu"] / REUSE_CALLS * 1000, 2)
        figures[f"{key}.wall_ms_per_call"] = round(total["wall"] / REUSE_CALLS * 1000, 2)
        figures[f"{key}.connections_per_call_after_idle"] = round(idle[way] / IDLE_CALLS, 2)
    figures["http.reuse.calls"] = REUSE_CALLS
    figures["http.reuse.idle_s"] = IDLE_S
    return figures


async def _json_calls(url: str, pid: int) -> dict[str, object]:
    """A `--json-response` server (as the harness starts its fleets): the CPU and time of REUSE_CALLS
    calls through robocog's SDK path and through the lean client a study's fleets use (`lean` over
    `json_http`), alternating in rounds, to set beside `_reuse`'s event-stream answers."""
    from mcp_types import Implementation

    from robocog.agent.client.connection import _http_transport
    from robocog.agent.client.json_http import json_http_channel
    from robocog.agent.client.lean import LeanClient
    from robocog.agent.client.output_schemas import share_validators

    totals = {way: [0.0, 0.0, 0.0] for way in ("robocog", "lean")}
    info = Implementation(name="robocog", version="bench")
    async with (
        Client(_http_transport(url, None), mode="legacy") as ours,
        json_http_channel(url) as channel,
        LeanClient(channel, client_info=info, name=url) as lean,
    ):
        # as `connect` does: the tools listed, their validators shared
        share_validators(ours.session, (await ours.list_tools()).tools)
        await lean.list_tools()
        for client in (ours, lean):
            await client.call_tool("look_around", {})
        for _ in range(REUSE_ROUNDS):
            for way, client in (("robocog", ours), ("lean", lean)):
                c0, s0, t0 = time.process_time(), _cpu_s(pid), time.perf_counter()
                for _ in range(REUSE_CALLS // REUSE_ROUNDS):
                    await client.call_tool("look_around", {})
                total = totals[way]
                total[0] += time.process_time() - c0
                total[1] += _cpu_s(pid) - s0
                total[2] += time.perf_counter() - t0
    figures: dict[str, object] = {}
    for way, (client_s, server_s, wall_s) in totals.items():
        key = f"http.json_response.{way}"
        figures[f"{key}.client_cpu_ms_per_call"] = round(client_s / REUSE_CALLS * 1000, 2)
        figures[f"{key}.server_cpu_ms_per_call"] = round(server_s / REUSE_CALLS * 1000, 2)
        figures[f"{key}.wall_ms_per_call"] = round(wall_s / REUSE_CALLS * 1000, 2)
    return figures


def _reuse_in_child(url: str, pid: int, mode: str = "--reuse") -> dict[str, object]:
    """`_reuse` in a process of its own: `make bench` runs every bench in one process, and the threads
    an earlier bench left behind (an in-process server's) would count in this client's CPU and time."""
    command = [sys.executable, __file__, mode, url, str(pid)]
    done = subprocess.run(command, capture_output=True, text=True, check=True, timeout=600)
    figures: dict[str, object] = json.loads(done.stdout)
    return figures


def _pct(values: list[float], q: float) -> float:
    return round(statistics.quantiles(values, n=100)[int(q) - 1], 2)


def _sessions(url: str, pid: int) -> dict[str, float]:
    headers = {
        "accept": "application/json, text/event-stream",
        "content-type": "application/json",
        "authorization": f"Bearer {TOKEN}",
    }
    figures: dict[str, float] = {}
    with httpx.Client(headers=headers, timeout=10) as http:
        figures["http.sessions.rss_before_mb"] = round(_rss_mb(pid), 1)
        opened = []
        for _ in range(MAX_SESSIONS):
            response = http.post(url, json=INITIALIZE)
            assert response.status_code == 200, response.text
            opened.append(response.headers["mcp-session-id"])
        figures["http.sessions.rss_at_cap_mb"] = round(_rss_mb(pid), 1)
        refused = sum(http.post(url, json=INITIALIZE).status_code == 503 for _ in range(REFUSED))
        figures["http.sessions.refused_past_cap"] = refused
        figures["http.sessions.rss_after_refusals_mb"] = round(_rss_mb(pid), 1)
        for session in opened:
            http.delete(url, headers={"mcp-session-id": session})
        time.sleep(1.0)
        figures["http.sessions.rss_after_close_mb"] = round(_rss_mb(pid), 1)
        again = http.post(url, json=INITIALIZE)
        figures["http.sessions.open_after_close_ok"] = again.status_code == 200
    return figures


def run() -> dict[str, object]:
    figures: dict[str, object] = {}
    with tempfile.TemporaryDirectory() as data:
        for label, extra, token in (("open", (), None), ("token", ("--auth-token", TOKEN), TOKEN)):
            proc, url = _start(f"{data}/{label}", *extra, "--max-sessions", str(MAX_SESSIONS))
            try:
                times = anyio.run(_round_trips, url, token)
                figures[f"http.look_around_{label}.p50_ms"] = round(statistics.median(times), 2)
                figures[f"http.look_around_{label}.p99_ms"] = _pct(times, 99)
                if token is None:
                    figures.update(_reuse_in_child(url, proc.pid))
                else:
                    figures.update(_sessions(url, proc.pid))
            finally:
                proc.terminate()
                proc.wait(timeout=10)
        proc, url = _start(f"{data}/json", "--json-response")
        try:
            figures.update(_reuse_in_child(url, proc.pid, "--json"))
        finally:
            proc.terminate()
            proc.wait(timeout=10)
    return figures


if __name__ == "__main__":
    if sys.argv[1:2] in (["--reuse"], ["--json"]):
        measure = _reuse if sys.argv[1] == "--reuse" else _json_calls
        print(json.dumps(anyio.run(measure, sys.argv[2], int(sys.argv[3]))))
    else:
        print(json.dumps(run(), indent=2))
