"""HTTP: many MCP clients at once against `robocog-server --transport http`, read-only calls each;
errors, p50/p99 and throughput."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import anyio

from tests.bench.fuzz_server_process import start_http_server
from tests.bench.fuzz_stdio import percentile

#: Read-only calls, so that no client needs to hold the robot (one session drives it at a time).
HTTP_CALLS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("look_around", {}),
    ("view_scratchpad", {}),
    ("search_memory", {"query": "Put away all the items into the shelf."}),
    ("resource", {"uri": "robocog://world/state"}),
)


async def http_clients(url: str, clients: int, calls: int) -> tuple[list[float], list[str]]:
    """`clients` MCP sessions at once, `calls` read-only calls each; (latencies, errors)."""
    from mcp import Client

    latencies: list[float] = []
    errors: list[str] = []

    async def one(index: int) -> None:
        try:
            async with Client(url) as client:
                for i in range(calls):
                    tool, arguments = HTTP_CALLS[(index + i) % len(HTTP_CALLS)]
                    start = time.perf_counter()
                    if tool == "resource":
                        await client.read_resource(arguments["uri"], cache_mode="bypass")
                    else:
                        result = await client.call_tool(tool, arguments)
                        if result.is_error:
                            errors.append(f"client {index} {tool}: {result.content}")
                    latencies.append(time.perf_counter() - start)
        except Exception as exc:  # boundary: every failure of a client is a figure
            errors.append(f"client {index}: {type(exc).__name__}: {exc}")

    async with anyio.create_task_group() as tg:
        for index in range(clients):
            tg.start_soon(one, index)
    return latencies, errors


async def warm_up(url: str) -> None:
    from mcp import Client

    async with Client(url) as client:
        await client.call_tool("look_around", {})  # waits for the world
        await client.call_tool("search_memory", {"query": "warm up"})  # loads the embedding model


def fuzz_http(clients: int, calls: int, work: Path) -> dict[str, Any]:
    proc, url = start_http_server(work)
    try:
        anyio.run(warm_up, url)
        start = time.perf_counter()
        latencies, errors = anyio.run(http_clients, url, clients, calls)
        wall = time.perf_counter() - start
        alive = proc.poll() is None
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    return {
        "http.clients": clients,
        "http.calls_per_client": calls,
        "http.calls_answered": len(latencies),
        "http.errors": len(errors),
        "http.call_p50_ms": round(percentile(latencies, 0.5) * 1e3, 2),
        "http.call_p99_ms": round(percentile(latencies, 0.99) * 1e3, 2),
        "http.calls_per_s": round(len(latencies) / wall, 1),
        "http.server_alive_after": alive,
        "http.first_errors": errors[:5],
    }
