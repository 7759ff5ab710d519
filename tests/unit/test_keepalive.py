"""The HTTP client's answers read to their end on close, so that httpcore keeps their connection:
a reader that stops at the answer's event leaves the stream's end unread, which closing now reads;
a stream that does not end is closed all the same, and GET streams are left as they are."""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import httpx2
import pytest

from robocog.agent.client import keepalive
from robocog.agent.client.keepalive import KeepAliveTransport

pytestmark = pytest.mark.anyio


class Body(httpx2.AsyncByteStream):
    """A response body of `parts`, then (when `endless`) silence; it records what was read and closed."""

    def __init__(self, parts: list[bytes], *, endless: bool = False) -> None:
        self.parts, self.endless, self.read, self.closed = parts, endless, 0, False

    async def __aiter__(self) -> AsyncIterator[bytes]:
        for part in self.parts:
            self.read += 1
            yield part
        if self.endless:
            await anyio.sleep_forever()

    async def aclose(self) -> None:
        self.closed = True


class Inner(httpx2.AsyncBaseTransport):
    def __init__(self, body: Body) -> None:
        self.body = body

    async def handle_async_request(self, request: httpx2.Request) -> httpx2.Response:
        return httpx2.Response(200, stream=self.body, request=request)


async def _first_part(method: str, body: Body) -> bytes:
    async with (
        httpx2.AsyncClient(transport=KeepAliveTransport(Inner(body))) as client,
        client.stream(method, "http://robot/mcp") as response,
    ):
        async for part in response.aiter_raw():
            return part  # as the SDK does: the answer's event is here, the rest is not read
    raise AssertionError("no body")


async def test_closing_an_answer_reads_the_rest_of_it_then_closes_it() -> None:
    body = Body([b"event: message\n\n", b"", b"end"])
    assert await _first_part("POST", body) == b"event: message\n\n"
    assert body.read == 3 and body.closed


async def test_an_answer_that_does_not_end_is_closed_after_the_wait(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(keepalive, "DRAIN_S", 0.01)
    body = Body([b"first", b"second"], endless=True)
    await _first_part("POST", body)
    assert body.read == 2 and body.closed


async def test_a_get_stream_is_closed_without_reading_on() -> None:
    body = Body([b"first", b"second", b"third"])
    await _first_part("GET", body)
    assert body.read == 1 and body.closed
