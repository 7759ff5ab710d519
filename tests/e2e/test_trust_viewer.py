"""The live viewer's readers cannot slow the robot down or grow without bound: 300 readers against a
real `robocog-server --view` (stdio, real PyBullet): past the cap they get a clear 503, the ones
admitted all get the same bytes for an event while the robot moves, and a closed reader frees its
place. (The latency of `move_to` with 0 and 300 readers is a figure: tests/bench/bench_trust.py.)"""

from __future__ import annotations

from contextlib import AsyncExitStack
from pathlib import Path

import anyio
import httpx
import pytest

from robocog.server.viewer import MAX_READERS
from tests.helpers import live_server

pytestmark = pytest.mark.anyio
READERS = 300


async def first_result_event(response: httpx.Response) -> bytes:
    """The bytes of the first `result` event a reader is sent."""
    buffer = b""
    async for chunk in response.aiter_raw():
        buffer += chunk
        for block in buffer.split(b"\n\n"):
            if b"event: result" in block:
                return block
    raise AssertionError("the stream ended without a result event")


async def test_readers_past_the_cap_get_503_and_the_admitted_all_see_the_move(tmp_path: Path) -> None:
    async with live_server(tmp_path / "memory") as (client, url):
        limits = httpx.Limits(max_connections=None, max_keepalive_connections=0)
        async with httpx.AsyncClient(base_url=url, timeout=60, limits=limits) as http, AsyncExitStack() as streams:
            with anyio.fail_after(60):
                while (await http.get("api/state")).status_code != 200:  # the robot is built
                    await anyio.sleep(0.1)
            responses: list[httpx.Response] = []

            async def open_reader() -> None:
                responses.append(await streams.enter_async_context(http.stream("GET", "api/events")))

            async with anyio.create_task_group() as tg:
                for _ in range(READERS):
                    tg.start_soon(open_reader)
            admitted = [r for r in responses if r.status_code == 200]
            refused = [r for r in responses if r.status_code == 503]
            assert (len(admitted), len(refused)) == (MAX_READERS, READERS - MAX_READERS)
            body = (await refused[0].aread()).decode()
            assert f"at most {MAX_READERS} event streams" in body and "close a viewer page" in body
            moved = await client.call_tool("move_to", {"location": "Hallway Area Door"})
            assert not moved.is_error
            seen: list[bytes] = []

            async def read(response: httpx.Response) -> None:
                seen.append(await first_result_event(response))

            with anyio.fail_after(60):
                async with anyio.create_task_group() as tg:
                    for response in admitted:
                        tg.start_soon(read, response)
            assert len(seen) == MAX_READERS and len(set(seen)) == 1, "every reader got the same bytes"
            assert b'"tool": "move_to"' in seen[0]
            await streams.aclose()  # the readers go: their places are free again
        async with httpx.AsyncClient(base_url=url, timeout=30) as http:
            with anyio.fail_after(30):
                while True:
                    async with http.stream("GET", "api/events") as again:
                        if again.status_code == 200:
                            break
                    await anyio.sleep(0.1)
        assert not (await client.call_tool("look_around", {})).is_error, "the server carries on"


def test_a_reader_that_keeps_up_is_sent_only_its_new_events() -> None:
    from robocog.server.events import EventBus

    bus = EventBus(backlog=500)
    for i in range(600):
        bus.publish("call", {"i": i})
    assert [e.seq for e in bus.since(598)] == [599, 600]
    assert bus.since(600) == [] and bus.since(50)[0].kind == "gap"
    event = bus.since(599)[0]
    assert event.encoded is event.encoded, "encoded once"


async def test_a_reader_gets_what_happened_in_one_write_per_tick() -> None:
    from robocog.server.events import EventBus

    bus = EventBus()
    chunks: list[bytes] = []

    async def reader() -> None:
        async for chunk in bus.batches(0, heartbeat_s=60, tick_s=0.2):
            chunks.append(chunk)
            if b"event: state" in chunk:
                bus.close()

    async with anyio.create_task_group() as tg:
        tg.start_soon(reader)
        bus.publish("call", {"tool": "move_to"})
        await anyio.sleep(0.05)  # the reader wrote the call and waits for its tick
        bus.publish("result", {"tool": "move_to"})
        bus.publish("state", {"world": {}})
    assert len(chunks) == 2, "the result and the state that came within one tick: one write"
    assert chunks[1].count(b"event: ") == 2 and chunks[1] == b"".join(e.encoded for e in bus.since(1))
