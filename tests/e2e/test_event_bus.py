"""The event bus behind the live viewer: each call and its result published, failures re-raised, a
bounded backlog that tells a late reader of the gap, the episode's verdicts, live following."""

from __future__ import annotations

import base64
import json
from typing import Any

import anyio
import pytest
from mcp_types import CallToolResult, ImageContent, TextContent

from robocog.server.events import EventBus


def _result(text: str, *, image: bytes | None = None, structured: dict[str, Any] | None = None) -> CallToolResult:
    content: list[TextContent | ImageContent] = [TextContent(type="text", text=text)]
    if image is not None:
        content.append(ImageContent(type="image", data=base64.b64encode(image).decode(), mime_type="image/png"))
    return CallToolResult(content=content, structured_content=structured, is_error=False)


# --- the event bus ---------------------------------------------------------------------------------


@pytest.mark.anyio
async def test_bus_publishes_each_call_and_its_result() -> None:
    bus = EventBus()

    async def call() -> CallToolResult:
        return _result("{}", structured={"status": "success", "message": "moved to Kitchen Shelf", "path": ["A"]})

    await bus.observe("move_to", {"location": "Kitchen Shelf"}, call, client="test/1")
    started, finished = bus.since(0)
    assert (started.kind, started.data["tool"], started.data["arguments"]) == (
        "call",
        "move_to",
        {"location": "Kitchen Shelf"},
    )
    assert finished.kind == "result" and finished.data["call"] == started.seq
    assert finished.data["summary"] == "moved to Kitchen Shelf" and finished.data["is_error"] is False
    assert finished.data["structured"]["path"] == ["A"]
    assert json.loads(finished.sse().decode().split("data: ", 1)[1])["tool"] == "move_to"


@pytest.mark.anyio
async def test_bus_reports_a_failed_call_and_reraises() -> None:
    bus = EventBus()

    async def call() -> CallToolResult:
        raise ValueError("no location called Moon")

    with pytest.raises(ValueError):
        await bus.observe("move_to", {"location": "Moon"}, call)
    result = bus.since(0)[-1]
    assert result.data["is_error"] is True and "Moon" in result.data["summary"]


@pytest.mark.anyio
async def test_bus_keeps_a_bounded_backlog_and_tells_a_late_reader_of_the_gap() -> None:
    bus = EventBus(backlog=10, images=2)
    for i in range(20):

        async def call(i: int = i) -> CallToolResult:
            return _result(f"call {i}", image=b"png%d" % i)

        await bus.observe("look", {"direction": "ahead"}, call)
    assert len(bus.recent(100)) == 10
    (gap,) = bus.since(0)
    assert gap.kind == "gap" and gap.data["missed"] == 30
    assert [e.seq for e in bus.since(35)] == list(range(36, 41))
    kept = [seq for seq in range(1, 41) if bus.image(seq) is not None]
    assert kept == [38, 40] and bus.image(40) == b"png19"


@pytest.mark.anyio
async def test_bus_keeps_the_verdicts_of_the_episode() -> None:
    bus = EventBus()

    async def ended() -> CallToolResult:
        return _result("{}", structured={"status": "success", "message": "recorded", "episode": 1})

    async def checked() -> CallToolResult:
        return _result("{}", structured={"task_id": "T1", "success": False, "reason": "the mug is on the table"})

    async def began() -> CallToolResult:
        return _result("{}", structured={"status": "success", "message": "episode 2"})

    await bus.observe("end_task", {"status": "success", "summary": "put all away", "description": "T1"}, ended)
    await bus.observe("check_task", {"task_id": "T1"}, checked)
    assert bus.verdicts["believed"]["status"] == "success" and bus.verdicts["truth"]["success"] is False
    assert bus.since(0)[-1].data["verdicts"]["truth"]["reason"] == "the mug is on the table"
    await bus.observe("begin_task", {"task_id": "T2"}, began)
    assert bus.verdicts == {}


@pytest.mark.anyio
async def test_bus_follow_delivers_live_events_and_snapshots() -> None:
    bus = EventBus()
    seen: list[str] = []
    reads = 0

    async def snapshot() -> dict[str, Any]:
        nonlocal reads
        reads += 1
        return {"robot": {"location": "Kitchen Shelf"}}

    async def reader() -> None:
        async for event in bus.follow(0):
            assert event is not None
            seen.append(event.kind)
            if event.kind == "state":
                bus.close()

    async def call() -> CallToolResult:
        return _result("ok", structured={"status": "success", "message": "ok"})

    async with anyio.create_task_group() as tg:
        tg.start_soon(reader)
        tg.start_soon(bus.snapshots, snapshot)
        await bus.observe("grab", {"object": "cube"}, call)
    assert seen == ["call", "result", "state"] and reads == 1
    assert bus.state == {"robot": {"location": "Kitchen Shelf"}}
