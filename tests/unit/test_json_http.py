"""robocog's lean streamable HTTP transport (`robocog.agent.client.json_http`) under the SDK's own
`Client`, against a raw HTTP/1.1 server on loopback that plays an MCP server answering in JSON: the
session's headers on every request, one connection, the `DELETE` at the end, every error status as
the request's error, and cancellation in both eras."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest
from mcp import Client
from mcp.shared.message import ClientMessageMetadata, SessionMessage
from mcp_types import JSONRPCNotification, JSONRPCRequest

from robocog.agent.client.connection import ServerSpec, connect, leaf_message
from robocog.agent.client.json_http import JsonHttpLink, json_http_streams
from tests.helpers import served

pytestmark = pytest.mark.anyio

LEGACY, MODERN = "2025-11-25", "2026-07-28"
SESSION = "s-123"
#: What `connect` asks for besides `initialize`, answered (an empty catalogue: no resources).
TOOLS = ("fine", "bad", "gone", "broken", "moved", "accepted", "stream", "garbled", "slow", "refused")
CONNECT_ANSWERS: dict[str, dict[str, Any]] = {
    "tools/list": {"tools": [{"name": name, "inputSchema": {"type": "object"}} for name in TOOLS]},
    "prompts/get": {"messages": [{"role": "user", "content": {"type": "text", "text": "You drive a robot."}}]},
    "resources/read": {"contents": [{"uri": "robocog://tasks", "mimeType": "application/json", "text": "[]"}]},
}


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"  # aiohttp runs on asyncio only


def answer(writer: asyncio.StreamWriter, status: str, body: bytes = b"", **headers: str) -> None:
    head = "".join(f"{k.replace('_', '-')}: {v}\r\n" for k, v in headers.items())
    writer.write(f"HTTP/1.1 {status}\r\n{head}content-length: {len(body)}\r\n\r\n".encode() + body)


def result(request_id: Any, value: dict[str, Any]) -> bytes:
    return json.dumps({"jsonrpc": "2.0", "id": request_id, "result": value}).encode()


class FakeServer:
    """An MCP server in JSON mode, in a few lines: it records every request's method line, headers
    and message, and answers `tools/call` by the tool's name."""

    def __init__(self) -> None:
        self.seen: list[tuple[str, dict[str, str], dict[str, Any] | None]] = []
        self.dropped = asyncio.Event()  # a POST whose connection the client closed before its answer

    async def __call__(self, raw: bytes, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        head, _, body = raw.partition(b"\r\n\r\n")
        first, *lines = head.decode().split("\r\n")
        headers = {k.strip().lower(): v.strip() for k, v in (line.split(":", 1) for line in lines)}
        message = json.loads(body) if body else None
        self.seen.append((first, headers, message))
        if first.startswith("DELETE"):
            return answer(writer, "200 OK")
        if first.startswith("GET"):  # the SDK's stream for the server's own notifications: none here
            return answer(writer, "405 Method Not Allowed")
        assert message is not None
        method, request_id = message.get("method"), message.get("id")
        if method == "initialize":
            version = message["params"]["protocolVersion"]
            value = {
                "protocolVersion": version,
                "capabilities": {"tools": {}},
                "serverInfo": {"name": "f", "version": "1"},
            }
            return answer(
                writer, "200 OK", result(request_id, value), content_type="application/json", mcp_session_id=SESSION
            )
        if request_id is None:  # a notification
            return answer(writer, "202 Accepted")
        if method in CONNECT_ANSWERS:
            return answer(
                writer, "200 OK", result(request_id, CONNECT_ANSWERS[method]), content_type="application/json"
            )
        await self.tool(message["params"]["name"], request_id, reader, writer)

    async def tool(
        self, name: str, request_id: Any, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        if name == "fine":
            text = {"content": [{"type": "text", "text": "done"}], "isError": False}
            answer(writer, "200 OK", result(request_id, text), content_type="application/json; charset=utf-8")
        elif name == "bad":
            error = {"jsonrpc": "2.0", "id": None, "error": {"code": -32602, "message": "no such object: vase"}}
            answer(writer, "400 Bad Request", json.dumps(error).encode(), content_type="application/json")
        elif name == "gone":
            answer(writer, "404 Not Found", b"no session")
        elif name == "broken":
            answer(writer, "500 Internal Server Error", b"oops", content_type="text/plain")
        elif name == "moved":
            answer(writer, "307 Temporary Redirect", location="http://elsewhere.example/mcp")
        elif name == "accepted":
            answer(writer, "202 Accepted")
        elif name == "stream":
            answer(writer, "200 OK", b"event: message\ndata: {}\n\n", content_type="text/event-stream")
        elif name == "garbled":
            answer(writer, "200 OK", b"{not json", content_type="application/json")
        elif name == "slow":  # never answers: waits for the client to hang up
            await reader.read()
            self.dropped.set()
            raise ConnectionError
        elif name == "refused":
            answer(writer, "401 Unauthorized", b"")

    def methods(self) -> list[str]:
        return [m["method"] if m and "method" in m else first.split()[0] for first, _, m in self.seen]


@asynccontextmanager
async def session(url: str, link: JsonHttpLink | None = None) -> AsyncIterator[Client]:
    async with Client(json_http_streams(link or JsonHttpLink(url, "tok", keepalive_s=15)), mode="legacy") as client:
        yield client


async def test_every_request_carries_the_session_over_one_connection_and_the_session_is_deleted() -> None:
    server = FakeServer()
    async with served(server) as url:
        link = JsonHttpLink(url, "tok", keepalive_s=15)
        async with session(url, link) as client:
            await client.list_tools()
            for _ in range(3):
                called = await client.call_tool("fine", {"n": 1})
                assert not called.is_error and called.content[0].text == "done"  # type: ignore[union-attr]
        assert link.connections_opened == 1
    assert server.methods() == ["initialize", "notifications/initialized", "tools/list", *["tools/call"] * 3, "DELETE"]
    (first, init_headers, _), *later = server.seen
    assert first == "POST /mcp HTTP/1.1" and "mcp-session-id" not in init_headers
    for _, headers, _ in later:  # every later request: the session, its version, the token
        assert headers["mcp-session-id"] == SESSION and headers["authorization"] == "Bearer tok"
        assert headers["mcp-protocol-version"] == LEGACY
        assert not any("aiohttp" in value.lower() for value in headers.values())
    call = later[2][2]
    assert call is not None and isinstance(call.pop("id"), int)
    assert call == {"jsonrpc": "2.0", "method": "tools/call", "params": {"name": "fine", "arguments": {"n": 1}}}


@pytest.mark.parametrize(
    ("tool", "says"),
    [
        ("bad", "no such object: vase"),  # the server's own JSON-RPC error, under this request's id
        ("gone", "Session terminated"),
        ("broken", "Server returned an error response"),
        ("moved", "Redirect to http://elsewhere.example/mcp not followed"),
        ("accepted", "server answered a request with 202 Accepted"),
        ("stream", "Unexpected content type: text/event-stream"),
        ("garbled", "Failed to parse JSON response"),
    ],
)
async def test_an_answer_that_is_not_a_result_is_the_request_s_error_and_the_session_goes_on(
    tool: str, says: str
) -> None:
    server = FakeServer()
    async with served(server) as url, session(url) as client:
        with pytest.raises(Exception, match=says):
            await client.call_tool(tool, {})
        assert not (await client.call_tool("fine", {})).is_error  # the next call is answered as before


async def test_a_refused_token_ends_the_connection_with_the_sentence_that_says_what_to_do() -> None:
    server = FakeServer()
    async with served(server) as url:
        with pytest.raises(BaseException) as caught:
            async with connect(ServerSpec(url=url, auth_token=None, json_answers=True)) as robot:
                await robot.client.call_tool("refused", {})
    assert "ServerConnectionError" in leaf_message(caught.value)
    assert "refused the connection: it needs a bearer token (set ROBOCOG_AUTH_TOKEN" in leaf_message(caught.value)


@pytest.mark.parametrize("json_answers", [True, False])
async def test_the_spec_says_which_transport_connects(json_answers: bool) -> None:
    server = FakeServer()
    async with served(server) as url, connect(ServerSpec(url=url, json_answers=json_answers)) as robot:
        assert robot.system_prompt == "You drive a robot." and robot.tasks == {}
    agents = {headers.get("user-agent", "") for _, headers, _ in server.seen}
    assert any("httpx" in agent for agent in agents) is not json_answers  # the SDK's client is httpx


async def pump_one(url: str, version: str, server: FakeServer) -> bool:
    """A request sent at `version`, then its cancellation, straight through the link's pump; whether
    the request's POST was closed by then."""
    link = JsonHttpLink(url, None, keepalive_s=15)
    up_writer, up = anyio.create_memory_object_stream[SessionMessage | Exception](10)
    down, down_reader = anyio.create_memory_object_stream[SessionMessage](0)
    stamp = ClientMessageMetadata(headers={"mcp-protocol-version": version})
    request = JSONRPCRequest(jsonrpc="2.0", id=7, method="tools/call", params={"name": "slow"})
    cancel = JSONRPCNotification(jsonrpc="2.0", method="notifications/cancelled", params={"requestId": 7})
    try:
        async with anyio.create_task_group() as tg, up_writer, up:
            tg.start_soon(link.pump, down_reader, up_writer, tg)
            await down.send(SessionMessage(request, metadata=stamp))
            while not any(m and m.get("id") == 7 for _, _, m in server.seen):
                await anyio.sleep(0.01)
            await down.send(SessionMessage(cancel, metadata=stamp))
            await down.aclose()
            with anyio.fail_after(5):
                if version == MODERN:
                    await server.dropped.wait()
                else:
                    while "notifications/cancelled" not in server.methods():
                        await anyio.sleep(0.01)
                    await anyio.sleep(0.2)  # time enough for a wrongly closed POST to show
            dropped = server.dropped.is_set()
            tg.cancel_scope.cancel()
    finally:
        await link.close(terminate=False)
    return dropped


async def test_at_2026_a_cancellation_closes_the_request_s_post_and_sends_no_frame() -> None:
    server = FakeServer()
    async with served(server) as url:
        assert await pump_one(url, MODERN, server)
    assert "notifications/cancelled" not in server.methods()


async def test_below_2026_a_cancellation_is_posted_as_its_frame() -> None:
    server = FakeServer()
    async with served(server) as url:
        assert not await pump_one(url, LEGACY, server), "below 2026 the POST stays open: the frame is the signal"
    sent = [m for _, _, m in server.seen if m and m.get("method") == "notifications/cancelled"]
    assert sent == [{"jsonrpc": "2.0", "method": "notifications/cancelled", "params": {"requestId": 7}}]
