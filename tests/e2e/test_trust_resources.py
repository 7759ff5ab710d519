"""Bounded resources: a fleet that serves 200 memory namespaces keeps its memory bounded (it closes
them past `--memory-namespaces` and opens again those used next, their records intact), and the
namespace rule holds as the README says it once: robots share the server's namespace unless
`reset_world(memory_namespace=...)` gives them another. A real HTTP server process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from tests.helpers import ROOT, call_ok, http_server, http_session, rss_mb, server_env

pytestmark = pytest.mark.anyio

NAMESPACES = 200
WARM_UP = 40
OPEN = 8


def fleet_args(tmp: Path) -> list[str]:
    """A fleet of two robots, with the harness controls, its memory in `tmp`."""
    return ["--profile", "eval", "--robots", "2", "--data-dir", str(tmp / "memory")]


def test_200_namespaces_keep_a_fleets_memory_bounded(tmp_path: Path) -> None:
    """Two robots of a real fleet (PyBullet, embedded Chroma) write to 200 namespaces, side by side,
    through the fleet's calls; past `OPEN` open namespaces the fleet closes them between calls. Measured
    in a process of its own, so that what other test modules left in this worker does not count."""
    code = (
        "import sys, anyio; from pathlib import Path; from tests.e2e.test_trust_resources import measure; "
        "anyio.run(measure, Path(sys.argv[1]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr[-3000:]


async def measure(tmp_path: Path) -> None:
    import anyio

    from robocog.server.config import SessionConfig
    from robocog.server.robots.fleet import Fleet
    from robocog.server.robots.ownership import Driver

    fleet = Fleet(SessionConfig(data_dir=tmp_path / "memory"), capacity=2, open_namespaces=OPEN)
    try:
        await anyio.to_thread.run_sync(fleet.build)
        robots = [await fleet.robot_for(Driver(("driver", n), n, None)) for n in ("one", "two")]

        def write(namespace: str) -> Any:
            def run(session: Any) -> None:
                session.use_namespace(namespace)
                session.memory.add(f"task of {namespace}", "success", f"did {namespace}")

            return run

        async def units(robot: Any, start: int, stop: int) -> None:
            for i in range(start, stop, 2):
                await fleet.call(robot, write(f"unit-{i}"))

        async def both(start: int, stop: int) -> None:  # both robots at once: closing waits for their calls
            async with anyio.create_task_group() as tg:
                tg.start_soon(units, robots[0], start, stop)
                tg.start_soon(units, robots[1], start + 1, stop)

        await both(0, WARM_UP)  # the embedding model, Chroma, the worker threads, the first closings
        before = rss_mb(os.getpid())
        await both(WARM_UP, NAMESPACES)
        grown = rss_mb(os.getpid()) - before
        # unbounded, 160 namespaces cost about 2.7 MB each (~430 MB); bounded, a few closings' noise
        assert grown < 100, f"RSS grew {grown:.0f} MB over {NAMESPACES - WARM_UP} namespaces"
        assert fleet.memories.open_namespaces() <= OPEN + 2 and fleet.memories.recycled >= 20

        def find(session: Any) -> list[str]:  # a namespace closed long ago opens again with its record
            session.use_namespace("unit-4")
            return [h.record.summary for h in session.memory.search("task of unit-4", k=1)]

        assert await fleet.call(robots[1], find) == ["did unit-4"]
    finally:
        fleet.close()


async def test_robots_share_the_servers_namespace_unless_told_otherwise(tmp_path: Path) -> None:
    with http_server(tmp_path / "server.log", *fleet_args(tmp_path)) as url:
        async with http_session(url) as a, http_session(url) as b:
            await call_ok(a, "end_task", status="failure", description="grasp the TV", summary="too heavy")
            found = await call_ok(b, "search_memory", query="grasp the TV")
            assert [r["summary"] for r in found["results"]] == ["too heavy"], "one namespace: shared"
            await call_ok(b, "reset_world", memory_namespace="b-own")
            assert (await call_ok(b, "search_memory", query="grasp the TV"))["results"] == []
            assert (await call_ok(b, "clear_memory"))["removed"] == 0, "b's clear_memory clears only b's namespace"
            assert len((await call_ok(a, "search_memory", query="grasp the TV"))["results"]) == 1


#: A client that takes a robot and then waits forever (until it is killed).
HOLDER = """
import sys, anyio
from mcp import Client
from mcp.client.streamable_http import streamable_http_client

async def main():
    async with Client(streamable_http_client(sys.argv[1]), mode="legacy") as client:
        assert not (await client.call_tool("move_to", {"location": "Kitchen Door"})).is_error
        print("holding", flush=True)
        await anyio.sleep(3600)

anyio.run(main)
"""


async def test_robots_of_clients_killed_mid_session_are_freed_promptly(tmp_path: Path) -> None:
    import signal

    import anyio

    # at INFO the log says which sessions were closed and why, should this ever fail
    with http_server(tmp_path / "server.log", *fleet_args(tmp_path), "--log-level", "INFO") as url:
        holders = [
            subprocess.Popen([sys.executable, "-c", HOLDER, url], stdout=subprocess.PIPE, env=server_env())
            for _ in range(2)
        ]
        try:
            for holder in holders:
                assert holder.stdout is not None and holder.stdout.readline().strip() == b"holding"
            async with http_session(url) as late:
                refused = await late.call_tool("look_around", {})
                assert refused.is_error and "all 2 robots" in str(refused.content)
            for holder in holders:
                os.kill(holder.pid, signal.SIGKILL)
                holder.wait()
            # both robots come back within seconds, not after --session-idle-s (600 s)
            async with http_session(url) as a, http_session(url) as b:
                for client in (a, b):
                    with anyio.fail_after(60):
                        while (result := await client.call_tool("look_around", {})).is_error:
                            await anyio.sleep(0.5)
                    assert isinstance(result.structured_content, dict)
                    assert result.structured_content["location"] == "Front Door", "recycled"
        finally:
            for holder in holders:
                if holder.poll() is None:
                    holder.kill()
                    holder.wait()


async def test_a_memory_used_again_and_again_is_closed_and_opened_again_intact(tmp_path: Path) -> None:
    """Chroma grows with every search after a write until its client stops: the robot's memory is
    closed every RECYCLE_USES uses (between calls), and what it holds is there after."""
    import anyio

    from robocog.server.config import SessionConfig
    from robocog.server.robots.fleet import RECYCLE_USES, Fleet

    fleet = Fleet(SessionConfig(data_dir=tmp_path / "memory"))  # one robot for all, as a desktop server
    try:
        robot = await anyio.to_thread.run_sync(fleet.build)

        def write_and_search(i: int) -> Any:
            def run(session: Any) -> list[str]:
                session.memory.add(f"task {i}", "success", f"did {i}")
                return [h.record.summary for h in session.memory.search("task 0", k=1)]

            return run

        for i in range(RECYCLE_USES // 2 + 5):  # two uses a call
            assert await fleet.call(robot, write_and_search(i)) == ["did 0"]
        assert fleet.memories.recycled == 1
        assert await fleet.call(robot, lambda s: s.memory.count()) == RECYCLE_USES // 2 + 5
    finally:
        fleet.close()


async def test_a_units_namespace_can_be_dropped_with_its_files_and_the_servers_cannot(tmp_path: Path) -> None:
    from robocog.server.app import build_server
    from robocog.server.config import SessionConfig

    data = tmp_path / "memory"
    server = build_server(SessionConfig(data_dir=data), profile="eval")

    def index_dirs() -> set[str]:  # embedded Chroma keeps each collection's index in a directory of its own
        return {p.name for p in data.iterdir() if p.is_dir()}

    async with Client(server, mode="legacy") as client:
        await call_ok(client, "end_task", status="success", description="kept", summary="the server's own")
        await call_ok(client, "reset_world", memory_namespace="unit-7")
        for i in range(3):
            await call_ok(client, "end_task", status="success", description=f"unit task {i}", summary="s")
        await call_ok(client, "search_memory", query="unit task")
        before = index_dirs()
        dropped = await call_ok(client, "clear_memory", drop=True)
        assert dropped["removed"] == 3 and dropped["freed_bytes"] > 0
        assert len(index_dirs()) < len(before), "the namespace's files are gone"
        found = await call_ok(client, "search_memory", query="kept")
        assert [r["summary"] for r in found["results"]] == ["the server's own"], "back in the server's namespace"
        refused = await client.call_tool("clear_memory", {"drop": True})
        assert refused.is_error and "is the server's own memory namespace" in str(refused.content)
        await call_ok(client, "reset_world", memory_namespace="unit-7")
        assert (await call_ok(client, "search_memory", query="unit task"))["results"] == [], "made anew, empty"
