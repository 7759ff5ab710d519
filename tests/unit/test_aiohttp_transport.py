"""httpx over aiohttp (`robocog.agent.client.aiohttp_transport`): the bytes httpx would send, a body
as it arrives, httpx's own decoding, and aiohttp's failures as the httpx errors the SDK expects,
against a raw HTTP/1.1 server on loopback."""

from __future__ import annotations

import asyncio
import gzip
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import httpx2
import pytest

from robocog.agent.client.aiohttp_transport import AiohttpTransport, transport_for
from tests.helpers import free_port, served

pytestmark = pytest.mark.anyio


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"  # aiohttp runs on asyncio only


@asynccontextmanager
async def client(**options: object) -> AsyncIterator[httpx2.AsyncClient]:
    async with httpx2.AsyncClient(transport=AiohttpTransport(), **options) as c:  # type: ignore[arg-type]
        yield c


async def test_a_post_sends_httpx_headers_and_body_and_keeps_its_connection() -> None:
    seen: list[bytes] = []

    async def echo(request: bytes, _: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        seen.append(request)
        writer.write(b'HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ncontent-length: 12\r\n\r\n{"ok": true}')

    async with served(echo) as url, client(headers={"Authorization": "Bearer t"}) as c:
        for n in range(3):
            response = await c.post(url, json={"n": n})
            assert response.status_code == 200 and response.json() == {"ok": True}
        transport = c._transport
        assert isinstance(transport, AiohttpTransport) and transport.connections_opened == 1
    head, _, body = seen[-1].partition(b"\r\n\r\n")
    lines = head.lower().split(b"\r\n")
    assert lines[0] == b"post /mcp http/1.1" and body == b'{"n":2}'
    assert b"authorization: bearer t" in lines and b"content-length: 7" in lines
    assert not any(b"aiohttp" in line for line in lines)  # httpx's User-Agent, not aiohttp's


async def test_a_chunked_stream_arrives_as_it_is_sent_and_gzip_is_decoded_once() -> None:
    later = asyncio.Event()

    async def stream(_: bytes, __: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(b"HTTP/1.1 200 OK\r\ncontent-type: text/event-stream\r\ntransfer-encoding: chunked\r\n\r\n")
        writer.write(b"11\r\ndata: first one\n\n\r\n")
        await writer.drain()
        await later.wait()
        writer.write(b"e\r\ndata: second\n\n\r\n0\r\n\r\n")

    async with served(stream) as url, client() as c, c.stream("GET", url) as response:
        parts = response.aiter_raw()
        assert await anext(parts) == b"data: first one\n\n"  # before the rest is even sent
        later.set()
        assert b"".join([part async for part in parts]) == b"data: second\n\n"

    packed = gzip.compress(b"hello " * 50)

    async def zipped(_: bytes, __: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(b"HTTP/1.1 200 OK\r\ncontent-encoding: gzip\r\ncontent-length: %d\r\n\r\n" % len(packed) + packed)

    async with served(zipped) as url, client() as c:
        assert (await c.get(url)).text == "hello " * 50


async def test_failures_are_httpx_errors() -> None:
    async with client() as c:
        with pytest.raises(httpx2.ConnectError):
            await c.post(f"http://127.0.0.1:{free_port()}/mcp", json={})

    async def silent(_: bytes, __: asyncio.StreamReader, ___: asyncio.StreamWriter) -> None:
        await asyncio.sleep(30)

    async with served(silent) as url, client(timeout=httpx2.Timeout(5.0, read=0.2)) as c:
        with pytest.raises(httpx2.ReadTimeout):
            await c.post(url, json={})

    async def cut_short(_: bytes, __: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(b"HTTP/1.1 200 OK\r\ncontent-length: 100\r\n\r\nonly this")
        await writer.drain()
        raise ConnectionError  # the server hangs up mid-answer

    async with served(cut_short) as url, client() as c:
        with pytest.raises(httpx2.RemoteProtocolError):
            await c.post(url, json={})

    async def garbage(_: bytes, __: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(b"this is not HTTP\r\n\r\n")

    async with served(garbage) as url, client() as c:
        with pytest.raises(httpx2.RemoteProtocolError):
            await c.post(url, json={})


def test_only_plain_http_goes_through_aiohttp() -> None:
    assert isinstance(transport_for("http://127.0.0.1:8765/mcp"), AiohttpTransport)
    assert isinstance(transport_for("HTTP://robot.local/mcp"), AiohttpTransport)
    assert isinstance(transport_for("https://robot.example/mcp"), httpx2.AsyncHTTPTransport)
