"""The lean client's channel over streamable HTTP, for a server that answers every POST with one JSON
body: the fleets a study starts itself (`robocog-server --json-response`, on this machine's loopback).

The SDK's streamable HTTP client serves any server: event streams, resumption, redirects within the
origin, a GET stream for the server's own notifications, TLS, proxies. For each message it builds an
httpx request (parsing the URL again), opens a task group in the sender's context, dumps the message
to a dict that httpx encodes, and reads the answer through httpx's response objects. Here each
request of `lean`'s client is one HTTP/1.1 POST on a connection kept alive for the whole attempt,
written and read by h11 (the HTTP/1.1 library under httpx: request line and headers checked, the
answer's status line, headers and body by length, in chunks or up to the connection's end) over
asyncio's streams, and its answer read back as one JSON body.

Why h11 alone and not httpx on it: httpx's client, httpcore's pool and anyio's streams cost a
fleet's harness 1.0-1.6 ms of CPU per request (branch `stack`), and the CPU of a fleet attempt over
its physics-only CPU rose from 1.39 to 1.51-1.53, past the 1.5 the project holds; h11 alone costs
about 0.1 ms a request (`make bench --only overhead` and `--only http` measure it: docs/figures.md).

What it does as the SDK's transport does: the session id from `initialize`'s answer on every later
request, with the negotiated `MCP-Protocol-Version` and the bearer token; a `202 Accepted` or an error
status as the request's JSON-RPC error (the server's own error body when it sent one); the SDK's
timeouts (`CONNECT_TIMEOUT_S`, `READ_TIMEOUT_S`); and a `DELETE` of the session when it closes, which
frees the fleet's robot at once. A `401` is `ServerConnectionError` with the same sentence as
robocog's SDK path. A connection idle past `keepalive_s` (the client's 60 s, under the server's 75 s)
is not used again; a request is never written twice (only a `DELETE` is written again
on a new connection when a kept-alive one turns out closed: a POST could have reached the server).

What it does better for a study: a server that cannot be reached, hangs up or never answers fails
the request it was sent, as that request's error (`CONNECTION_CLOSED`, naming the error), where the
SDK's transport ends the whole session from its task group and cancels whatever the caller was doing.
The episode loop then reports the server's failure, the harness records the attempt as broken and
reconnects, and a fleet that died is started again (`Runner.worker`, `Fleets.ensure`).

What it does not do, because the fleets never need it: TLS (an `https://` URL goes to the SDK's
client), read an event stream (an answer that is not JSON fails its request, naming the content
type), follow a redirect (it fails its request, naming the location), resume a stream, or open the GET
stream for notifications no worker subscribes to. Every other server, and every URL a user gives,
goes through the SDK's transport (`connection._http_transport`).
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any
from urllib.parse import urlsplit

import anyio
import h11
from mcp.shared.inbound import MCP_PROTOCOL_VERSION_HEADER
from mcp_types import CONNECTION_CLOSED, INTERNAL_ERROR, INVALID_REQUEST, METHOD_NOT_FOUND, PARSE_ERROR

from robocog.agent.client.protocols import Message
from robocog.shared.errors import ServerConnectionError

MCP_SESSION_ID = "mcp-session-id"
#: The SDK's own timeouts for streamable HTTP (`connection._http_transport`): connecting, and reading.
CONNECT_TIMEOUT_S, READ_TIMEOUT_S = 30.0, 300.0
#: The longest answer head and JSON body read (a tools/list is about 40 KB).
MAX_HEAD, MAX_BODY = 64 * 1024, 64 * 1024 * 1024
#: How much of an answer is read from the socket at a time.
READ_SIZE = 64 * 1024


class ProtocolError(ValueError):
    """An answer that is not HTTP/1.1 as h11 reads it, or one past this channel's limits."""


#: A server that cannot be reached, hangs up, answers garbage or never answers.
UNREACHABLE = (OSError, TimeoutError, ProtocolError)

logger = logging.getLogger(__name__)


def refused_sentence(url: str, token: str | None) -> str:
    """What a `401` means to the person running the client (the SDK path says the same)."""
    given = "the bearer token in $ROBOCOG_AUTH_TOKEN was refused" if token else "it needs a bearer token"
    return (
        f"the robot server at {url} refused the connection: {given} "
        "(set ROBOCOG_AUTH_TOKEN to the server's --auth-token)"
    )


class _Stale(Exception):
    """A kept-alive connection the server had closed before this request: nothing of it was answered."""


class _Connection:
    """One HTTP/1.1 connection, kept alive between requests; h11 writes the requests and reads the
    answers (status line, headers, a body by length, in chunks or up to the connection's end)."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer
        self.http = h11.Connection(h11.CLIENT, max_incomplete_event_size=MAX_HEAD)
        self.reused = False
        self.idle_since = time.monotonic()

    def close(self) -> None:
        self.writer.close()

    async def exchange(self, request: h11.Request, body: bytes) -> tuple[int, dict[str, str], bytes, bool]:
        """Send `request` with `body`; the answer's status, headers (names in lower case), body, and
        whether the connection may serve the next request."""
        http = self.http
        try:
            self.writer.write(http.send(request) + http.send(h11.Data(data=body)) + http.send(h11.EndOfMessage()))
            await self.writer.drain()
        except (ConnectionResetError, BrokenPipeError) as exc:
            if self.reused:
                raise _Stale from exc
            raise
        first = b""  # the answer's first bytes, for an error that quotes them
        status, size = 0, 0
        headers: dict[str, str] = {}
        parts: list[bytes] = []
        while True:
            try:
                event = http.next_event()
            except h11.RemoteProtocolError as exc:
                begins = first.split(b"\r\n", 1)[0][:60].decode("latin-1")
                raise ProtocolError(f"an answer that begins {begins!r} (h11: {exc})") from None
            if event is h11.NEED_DATA:
                try:
                    chunk = await self.reader.read(READ_SIZE)
                except ConnectionResetError as exc:
                    if self.reused and not first:
                        raise _Stale from exc
                    raise
                if not chunk and not first:
                    if self.reused:
                        raise _Stale
                    raise ConnectionResetError("the server closed the connection without answering")
                first = first or chunk
                http.receive_data(chunk)
            elif isinstance(event, h11.Response):
                status = event.status_code
                for name, value in event.headers:
                    key, text = name.decode("latin-1"), value.decode("latin-1")
                    headers[key] = f"{headers[key]}, {text}" if key in headers else text
            elif isinstance(event, h11.Data):
                size += len(event.data)
                if size > MAX_BODY:
                    raise ProtocolError(f"an answer longer than {MAX_BODY} bytes")
                parts.append(event.data)
            elif isinstance(event, h11.EndOfMessage):
                break
            # an informational answer (1xx) comes before the real one: read on
        keep = http.our_state is h11.DONE and http.their_state is h11.DONE
        if keep:
            http.start_next_cycle()
        return status, headers, b"".join(parts), keep


class JsonHttpLink:
    """One MCP session over streamable HTTP with JSON answers (a `lean.Channel`): POSTs over
    kept-alive HTTP/1.1 connections (one, unless requests overlap)."""

    def __init__(self, url: str, token: str | None, *, keepalive_s: float) -> None:
        self.url = url
        parts = urlsplit(url)
        if parts.scheme != "http" or not parts.hostname:
            raise ValueError(f"{url}: the lean client's channel takes http:// URLs only")
        self._host, self._port = parts.hostname, parts.port or 80
        self._path = ((parts.path or "/") + (f"?{parts.query}" if parts.query else "")).encode("ascii")
        authority = f"[{self._host}]" if ":" in self._host else self._host
        self._authority = (authority if parts.port is None else f"{authority}:{parts.port}").encode("ascii")
        self._token = token
        self._keepalive_s = keepalive_s
        self._idle: list[_Connection] = []
        self.session_id: str | None = None
        #: The protocol version `initialize` negotiated, sent with every later message.
        self.protocol_version: str | None = None
        #: TCP connections opened so far (a kept-alive channel opens one per session).
        self.connections_opened = 0

    def _request(self, method: str, body: bytes) -> h11.Request:
        headers = [(b"host", self._authority)]
        if method == "POST":
            headers += [(b"accept", b"application/json, text/event-stream"), (b"content-type", b"application/json")]
        if self._token:
            headers.append((b"authorization", b"Bearer " + self._token.encode("latin-1")))
        if self.session_id:
            headers.append((MCP_SESSION_ID.encode(), self.session_id.encode("latin-1")))
        if self.protocol_version:
            headers.append((MCP_PROTOCOL_VERSION_HEADER.encode(), self.protocol_version.encode("latin-1")))
        headers.append((b"content-length", str(len(body)).encode()))
        return h11.Request(method=method, target=self._path, headers=headers)

    async def _connection(self) -> _Connection:
        now = time.monotonic()
        while self._idle:
            connection = self._idle.pop()
            if now - connection.idle_since < self._keepalive_s:
                connection.reused = True
                return connection
            connection.close()  # idle too long: the server may be about to close it
        async with asyncio.timeout(CONNECT_TIMEOUT_S):  # asyncio's: a third of anyio's CPU, on every request
            reader, writer = await asyncio.open_connection(self._host, self._port)
        self.connections_opened += 1
        return _Connection(reader, writer)

    async def _exchange(self, method: str, body: bytes = b"") -> tuple[int, dict[str, str], bytes]:
        """One request and its answer, on a kept-alive connection when there is one (a `DELETE` is
        written again on a new one when the server had closed that one: see the module's docstring)."""
        for _ in range(2):
            connection = await self._connection()
            try:
                async with asyncio.timeout(READ_TIMEOUT_S):
                    status, headers, content, keep = await connection.exchange(self._request(method, body), body)
            except _Stale as stale:
                connection.close()
                if method == "DELETE":
                    continue
                raise ConnectionResetError("the server had closed the kept-alive connection") from stale
            except BaseException:  # the connection is in the middle of something: it serves no more
                connection.close()
                raise
            if keep:
                connection.idle_since = time.monotonic()
                self._idle.append(connection)
            else:
                connection.close()
            return status, headers, content
        raise ProtocolError("the server closed two connections in a row before answering")

    async def request(self, message: Message) -> Message:
        """POST a request; its answer, or the error that stands for one (see the module's docstring)."""
        request_id = message["id"]
        initialize = message["method"] == "initialize"
        if initialize:  # the handshake negotiates a session and a version afresh
            self.session_id = self.protocol_version = None
        try:
            status, headers, content = await self._exchange("POST", _dumps(message))
        except UNREACHABLE as exc:  # the request's error, where it was made: the session can close cleanly
            return _error(request_id, CONNECTION_CLOSED, self._unreachable(exc))
        if status == 401:
            raise ServerConnectionError(refused_sentence(self.url, self._token))
        content_type = headers.get("content-type", "").lower()
        if status == 202:
            return _error(request_id, INVALID_REQUEST, "server answered a request with 202 Accepted")
        if 300 <= status < 400:
            where = headers.get("location", "elsewhere")
            return _error(request_id, INVALID_REQUEST, f"Redirect to {where} not followed")
        if status >= 400:
            return self._error_answer(request_id, status, content_type, content)
        if not content_type.startswith("application/json"):
            return _error(request_id, INVALID_REQUEST, f"Unexpected content type: {content_type}")
        try:
            answer = json.loads(content)
        except ValueError as exc:
            return _error(request_id, PARSE_ERROR, f"Failed to parse JSON response: {exc}")
        if not isinstance(answer, dict) or answer.get("id") != request_id:
            said = f"not this request's answer: {content[:200]!r}"
            return _error(request_id, PARSE_ERROR, f"Failed to parse JSON response: {said}")
        if initialize and "result" in answer:
            self.session_id = headers.get(MCP_SESSION_ID)
            version = answer["result"].get("protocolVersion") if isinstance(answer["result"], dict) else None
            self.protocol_version = version if isinstance(version, str) else None
        return answer

    async def notify(self, message: Message) -> None:
        """POST a notification (best effort: one lost with the server, its next request says so)."""
        try:
            status, _, _ = await self._exchange("POST", _dumps(message))
        except UNREACHABLE:
            logger.debug("a notification was not delivered", exc_info=True)
            return
        if status == 401:
            raise ServerConnectionError(refused_sentence(self.url, self._token))

    def _unreachable(self, exc: BaseException) -> str:
        return f"the robot server at {self.url} is unreachable: {type(exc).__name__}: {exc}"

    def _error_answer(self, request_id: Any, status: int, content_type: str, content: bytes) -> Message:
        """A request's answer at an error status: the server's JSON-RPC error when it sent one, under
        this request's id; else one that the status spells (as the SDK's transport does)."""
        if content_type.startswith("application/json"):
            try:
                parsed = json.loads(content)
            except ValueError:
                parsed = None
            if isinstance(parsed, dict) and isinstance(parsed.get("error"), dict):
                return {"jsonrpc": "2.0", "id": request_id, "error": parsed["error"]}
        if status == 404:
            if self.session_id is None:
                return _error(request_id, METHOD_NOT_FOUND, "Not Found")
            return _error(request_id, INVALID_REQUEST, "Session terminated")
        return _error(request_id, INTERNAL_ERROR, "Server returned an error response")

    async def close(self, terminate: bool) -> None:
        """End the session on the server (`DELETE`, best effort) and close the connections."""
        try:
            if terminate and self.session_id:
                with anyio.move_on_after(5):
                    await self._exchange("DELETE")
        except UNREACHABLE:
            pass  # the server is gone already: its sessions with it
        finally:
            for connection in self._idle:
                connection.close()
            self._idle.clear()


def _dumps(message: Message) -> bytes:
    return json.dumps(message, separators=(",", ":"), ensure_ascii=False).encode()


def _error(request_id: Any, code: int, message: str) -> Message:
    """The answer of a request that failed on its way: its caller learns why and does not wait on."""
    return {"jsonrpc": "2.0", "id": request_id, "error": {"code": code, "message": message}}


@asynccontextmanager
async def json_http_channel(
    url: str, token: str | None = None, *, keepalive_s: float = 15.0, terminate_on_close: bool = True
) -> AsyncIterator[JsonHttpLink]:
    """A channel to the server at `url`, which answers in JSON; its session deleted on leaving."""
    link = JsonHttpLink(url, token, keepalive_s=keepalive_s)
    try:
        yield link
    finally:
        with anyio.CancelScope(shield=True):
            await link.close(terminate_on_close)


__all__ = ["JsonHttpLink", "json_http_channel", "refused_sentence"]
