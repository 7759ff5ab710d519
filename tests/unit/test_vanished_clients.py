"""The HTTP server frees a vanished client's robot: its session is known from the moment the
initialize response names it, so the event stream its client opens at once is counted even while
the initialize request is still finishing (a race that left one killed client's robot held)."""

from __future__ import annotations

import anyio
import pytest
from starlette.types import Message, Receive, Scope, Send

from robocog.server.transport.http import GONE_GRACE_S, VanishedClients

pytestmark = pytest.mark.anyio


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


async def test_a_stream_opened_before_initialize_finishes_counts_and_its_end_frees_the_session() -> None:
    initialize_done, stream_open, stream_end = anyio.Event(), anyio.Event(), anyio.Event()

    async def app(scope: Scope, receive: Receive, send: Send) -> None:
        if scope["method"] == "POST":  # initialize: the id goes out, the request lingers
            await send({"type": "http.response.start", "status": 200, "headers": [(b"mcp-session-id", b"s1")]})
            await initialize_done.wait()
            await send({"type": "http.response.body", "body": b"", "more_body": False})
        else:  # the client's event stream, open until the client goes
            stream_open.set()
            await stream_end.wait()

    clock = Clock()
    watcher = VanishedClients(app, idle_s=600, clock=clock)

    async def nothing() -> Message:
        return {"type": "http.request", "body": b"", "more_body": False}

    async def sent(message: Message) -> None:
        return None

    def request(method: str, sid: bytes | None) -> Scope:
        headers = [(b"mcp-session-id", sid)] if sid else []
        return {"type": "http", "method": method, "path": "/mcp", "headers": headers, "query_string": b""}

    async with anyio.create_task_group() as tg:
        tg.start_soon(watcher, request("POST", None), nothing, sent)
        await anyio.wait_all_tasks_blocked()
        tg.start_soon(watcher, request("GET", b"s1"), nothing, sent)
        await stream_open.wait()
        assert watcher.sessions["s1"].streams == 1, "the stream is counted although initialize has not finished"
        initialize_done.set()
        await anyio.wait_all_tasks_blocked()
        clock.now += GONE_GRACE_S + 1
        assert watcher.gone(clock.now) == [], "a client with an open stream is there"
        stream_end.set()  # the client is killed: its stream ends
    clock.now += GONE_GRACE_S + 1
    assert watcher.gone(clock.now) == [("s1", "its client went away (its event stream closed)")]
