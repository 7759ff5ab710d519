"""HTTP access figures: what the bearer token costs a call, and what sessions cost and give back.

A real `robocog-server --transport http` process on a free loopback port:
- a read-only call (look_around) over one session, p50/p99, without and with a bearer token;
- sessions: RSS of the server before, with the cap (64) open, after 2,000 refused opens past the cap,
  and after every session was closed (DELETE), i.e. whether the memory comes back.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import anyio
import httpx
import httpx2
from mcp import Client
from mcp.client.streamable_http import streamable_http_client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import free_port, server_command

CALLS = 300
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
                if token is not None:
                    figures.update(_sessions(url, proc.pid))
            finally:
                proc.terminate()
                proc.wait(timeout=10)
    return figures


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
