"""robocog's lean client over streamable HTTP (`robocog.agent.client.lean` on `json_http`'s channel),
against a raw HTTP/1.1 server on loopback that plays an MCP server answering in JSON: the session's
headers on every request, one connection, the `DELETE` at the end, every error status as the
request's error, and a call given up (its timeout) told to the server."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import pytest
from mcp.shared.exceptions import MCPError
from mcp_types import CONNECTION_CLOSED, REQUEST_TIMEOUT, Implementation

from robocog.agent.client.connection import ServerSpec, connect, leaf_message, unreachable
from robocog.agent.client.json_http import JsonHttpLink, json_http_channel
from robocog.agent.client.lean import LeanClient
from tests.helpers import served

pytestmark = pytest.mark.anyio

LEGACY = "2025-11-25"
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
async def session(url: str, link: JsonHttpLink | None = None) -> AsyncIterator[LeanClient]:
    link = link or JsonHttpLink(url, "tok", keepalive_s=15)
    info = Implementation(name="robocog", version="test")
    try:
        async with LeanClient(link, client_info=info, name=url) as client:
            yield client
    finally:
        await link.close(terminate=True)


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
    (first, init_headers, init), *later = server.seen
    assert first == "POST /mcp HTTP/1.1" and "mcp-session-id" not in init_headers
    assert init is not None and init["params"] == {
        "protocolVersion": LEGACY,
        "capabilities": {},
        "clientInfo": {"name": "robocog", "version": "test"},
    }
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
        with pytest.raises(MCPError, match=says):
            await client.call_tool(tool, {})
        assert not (await client.call_tool("fine", {})).is_error  # the next call is answered as before


async def test_a_refused_token_ends_the_connection_with_the_sentence_that_says_what_to_do() -> None:
    server = FakeServer()
    async with served(server) as url:
        with pytest.raises(BaseException) as caught:
            async with connect(ServerSpec(url=url, auth_token=None, lean=True)) as robot:
                await robot.client.call_tool("refused", {})
    assert "ServerConnectionError" in leaf_message(caught.value)
    assert "refused the connection: it needs a bearer token (set ROBOCOG_AUTH_TOKEN" in leaf_message(caught.value)


@pytest.mark.parametrize("lean", [True, False])
async def test_the_spec_says_which_client_connects(lean: bool) -> None:
    server = FakeServer()
    async with served(server) as url, connect(ServerSpec(url=url, lean=lean)) as robot:
        assert robot.system_prompt == "You drive a robot." and robot.tasks == {}
        assert isinstance(robot.client, LeanClient) is lean
    agents = {headers.get("user-agent", "") for _, headers, _ in server.seen}
    assert any("httpx" in agent for agent in agents) is not lean  # the SDK's client is httpx


async def test_a_call_given_up_is_told_to_the_server_and_the_session_goes_on() -> None:
    server = FakeServer()
    async with served(server) as url, session(url) as client:
        with pytest.raises(MCPError) as timed_out:
            await client.call_tool("slow", {}, read_timeout_seconds=0.3)
        assert timed_out.value.error.code == REQUEST_TIMEOUT
        assert not (await client.call_tool("fine", {})).is_error
    sent = [m for _, _, m in server.seen if m and m.get("method") == "notifications/cancelled"]
    slow = next(m for _, _, m in server.seen if m and m.get("params", {}).get("name") == "slow")
    assert sent == [
        {
            "jsonrpc": "2.0",
            "method": "notifications/cancelled",
            "params": {"requestId": slow["id"], "reason": "timed out after 0.3s"},
        }
    ]


async def test_a_server_that_cannot_be_reached_fails_the_request_not_the_session() -> None:
    async with served(FakeServer()) as url:
        pass  # the port is closed again
    link = JsonHttpLink(url, None, keepalive_s=15)
    try:
        answer = await link.request({"jsonrpc": "2.0", "id": 1, "method": "tools/list"})
    finally:
        await link.close(terminate=True)
    assert answer["id"] == 1 and answer["error"]["code"] == CONNECTION_CLOSED
    assert answer["error"]["message"].startswith(f"the robot server at {url} is unreachable: ")
    assert unreachable(MCPError(**answer["error"]))


async def test_the_channel_deletes_its_session_on_leaving() -> None:
    server = FakeServer()
    async with served(server) as url, json_http_channel(url) as link:
        await link.request({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {"protocolVersion": LEGACY}})
        assert link.session_id == SESSION and link.protocol_version == LEGACY
    assert server.methods() == ["initialize", "DELETE"]


class Quirky(FakeServer):
    """The fake server, with answers in each of HTTP/1.1's ways of ending a body, and one that hangs
    up after answering without saying so (as a server closing an idle kept-alive connection does)."""

    async def tool(
        self, name: str, request_id: Any, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        body = result(request_id, {"content": [{"type": "text", "text": name}], "isError": False})
        if name == "chunked":
            half = len(body) // 2
            chunks = b"".join(b"%x\r\n%s\r\n" % (len(part), part) for part in (body[:half], body[half:]))
            writer.write(
                b"HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ntransfer-encoding: chunked\r\n\r\n"
                + chunks
                + b"0\r\n\r\n"
            )
        elif name == "until_close":  # no length: the body ends with the connection
            writer.write(b"HTTP/1.1 200 OK\r\ncontent-type: application/json\r\nconnection: close\r\n\r\n" + body)
            await writer.drain()
            raise ConnectionError
        elif name == "hang_up_after":
            answer(writer, "200 OK", body, content_type="application/json")
            await writer.drain()
            raise ConnectionError  # closed, without a `connection: close`
        elif name == "not_http":
            writer.write(b"SSH-2.0-OpenSSH_9.2\r\n\r\n")
        elif name == "huge_head":  # a header past the channel's 64 KB for an answer's head
            writer.write(b"HTTP/1.1 200 OK\r\nx-padding: " + b"a" * (256 * 1024) + b"\r\ncontent-length: 0\r\n\r\n")
        else:
            await super().tool(name, request_id, reader, writer)


@pytest.mark.parametrize("tool", ["chunked", "until_close"])
async def test_every_way_an_answer_ends_is_read_and_the_next_request_goes_on(tool: str) -> None:
    server = Quirky()
    async with served(server) as url:
        link = JsonHttpLink(url, None, keepalive_s=15)
        async with session(url, link) as client:
            called = await client.call_tool(tool, {})
            assert called.content[0].text == tool  # type: ignore[union-attr]
            assert not (await client.call_tool("fine", {})).is_error
        # a connection closed after its answer (said or not) is not used again: one more was opened
        assert link.connections_opened == (1 if tool == "chunked" else 2)


async def test_a_request_is_never_written_twice_on_a_connection_the_server_closed() -> None:
    """A server that hung up after an answer, without saying so: the next request, on that kept-alive
    connection, fails as the server's (it might have reached a server that died with it), the one after
    goes on a new connection, and the server saw each once."""
    server = Quirky()
    async with served(server) as url:
        link = JsonHttpLink(url, None, keepalive_s=15)
        async with session(url, link) as client:
            await client.call_tool("hang_up_after", {})
            with pytest.raises(MCPError, match="is unreachable: ConnectionResetError") as caught:
                await client.call_tool("fine", {"n": 1})
            assert unreachable(caught.value)
            opened = link.connections_opened
            assert not (await client.call_tool("fine", {"n": 2})).is_error
            assert link.connections_opened == opened + 1
    calls = [m["params"] for _, _, m in server.seen if m and m.get("method") == "tools/call"]
    assert calls == [{"name": "hang_up_after", "arguments": {}}, {"name": "fine", "arguments": {"n": 2}}]


async def test_a_connection_idle_past_the_keepalive_is_not_used_again() -> None:
    server = FakeServer()
    async with served(server) as url:
        link = JsonHttpLink(url, None, keepalive_s=0.2)
        async with session(url, link) as client:
            await client.call_tool("fine", {})
            opened = link.connections_opened
            await asyncio.sleep(0.3)
            await client.call_tool("fine", {})
            assert link.connections_opened == opened + 1


async def test_an_answer_that_is_not_http_fails_its_request_as_an_unreachable_server() -> None:
    async with served(Quirky()) as url, session(url) as client:
        with pytest.raises(MCPError, match=r"is unreachable: ProtocolError: an answer that begins 'SSH-2\.0") as caught:
            await client.call_tool("not_http", {})
        assert unreachable(caught.value)
        assert not (await client.call_tool("fine", {})).is_error


async def test_an_answer_whose_head_passes_64_kb_fails_its_request_and_the_next_goes_on() -> None:
    async with served(Quirky()) as url, session(url) as client:
        with pytest.raises(MCPError, match=r"is unreachable: ProtocolError: .*\(h11: ") as caught:
            await client.call_tool("huge_head", {})
        assert unreachable(caught.value)
        assert not (await client.call_tool("fine", {})).is_error


def test_the_channel_takes_plain_http_urls_only() -> None:
    with pytest.raises(ValueError, match="http:// URLs only"):
        JsonHttpLink("https://127.0.0.1:9/mcp", None, keepalive_s=15)
