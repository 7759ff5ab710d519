"""The MCP client's streams straight over aiohttp, for a server that answers every POST with one JSON
body: the fleets a study starts itself (`robocog-server --json-response`).

The SDK's streamable HTTP client serves any server: event streams, resumption, redirects within the
origin, a GET stream for the server's own notifications. For each message it builds an httpx request
(parsing the URL again), opens a task group in the sender's context, dumps the message to a dict that
httpx encodes, and reads the answer through httpx's response objects. Even with aiohttp under httpx
(`aiohttp_transport`), the harness spent about 1.5 ms of CPU per `look_around` on a fleet, against
about 1.0 ms through this transport (docs/figures.md, "HTTP connections"), and an attempt makes 24
calls. This transport keeps the SDK's `Client` and session (its requests, timeouts, cancellation and
validation) and replaces only the part under the two streams: each message is one POST of its JSON,
and the answer's one JSON body goes back up the read stream. One aiohttp pool keeps the connection
alive for the whole attempt.

What it does as the SDK's transport does: the session id from `initialize`'s answer on every later
request, the negotiated `MCP-Protocol-Version` (from the session's stamp), the message's own headers,
a `202 Accepted` or an error status as the request's JSON-RPC error (the server's own error body when
it sent one), a 2026 cancellation closing the POST it names (a cancellation frame POSTed below 2026),
and a `DELETE` of the session when it closes. A `401` is `ServerConnectionError` with the same
sentence as robocog's SDK path.

What it does better for a study: a server that cannot be reached, hangs up or never answers fails
the request it was sent, as that request's error (`CONNECTION_CLOSED`, naming aiohttp's error),
where the SDK's transport ends the whole session from its task group and cancels whatever the caller
was doing. The episode loop then reports the server's failure, the harness records the attempt as
broken and reconnects, and a fleet that died is started again (`Runner.worker`, `Fleets.ensure`).

What it does not do, because the fleets never need it: read an event stream (an answer that is not
JSON fails its request, naming the content type), follow a redirect (it fails its request, naming the
location), resume a stream, or open the GET stream for notifications no worker subscribes to. Every
other server, and every URL a user gives, goes through the SDK's transport (`connection._http_transport`).
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import aiohttp
import anyio
from anyio.abc import TaskGroup
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream
from mcp.shared.inbound import MCP_PROTOCOL_VERSION_HEADER
from mcp.shared.jsonrpc_dispatcher import cancelled_request_id_from_params
from mcp.shared.message import ClientMessageMetadata, SessionMessage
from mcp_types import (
    CONNECTION_CLOSED,
    INTERNAL_ERROR,
    INVALID_REQUEST,
    METHOD_NOT_FOUND,
    PARSE_ERROR,
    ErrorData,
    JSONRPCError,
    JSONRPCMessage,
    JSONRPCNotification,
    JSONRPCRequest,
    RequestId,
    jsonrpc_message_adapter,
)
from mcp_types.version import MODERN_PROTOCOL_VERSIONS
from pydantic import ValidationError
from yarl import URL

from robocog.agent.client.aiohttp_transport import pooled_session
from robocog.shared.errors import ServerConnectionError

MCP_SESSION_ID = "mcp-session-id"
#: The SDK's own timeouts for streamable HTTP (`connection._http_transport`): connecting, and reading.
CONNECT_TIMEOUT_S, READ_TIMEOUT_S = 30.0, 300.0

Reader = MemoryObjectSendStream[SessionMessage | Exception]
#: A server that cannot be reached, hangs up, answers garbage or never answers.
UNREACHABLE = (aiohttp.ClientError, OSError, TimeoutError)

logger = logging.getLogger(__name__)


def refused_sentence(url: str, token: str | None) -> str:
    """What a `401` means to the person running the client (the SDK path says the same)."""
    given = "the bearer token in $ROBOCOG_AUTH_TOKEN was refused" if token else "it needs a bearer token"
    return (
        f"the robot server at {url} refused the connection: {given} "
        "(set ROBOCOG_AUTH_TOKEN to the server's --auth-token)"
    )


class JsonHttpLink:
    """One MCP session over streamable HTTP with JSON answers: POSTs through one aiohttp pool."""

    def __init__(self, url: str, token: str | None, *, keepalive_s: float) -> None:
        self.url = url
        self._target = URL(url, encoded=True)  # parsed once, not per request
        self._token = token
        self._keepalive_s = keepalive_s
        self._http: aiohttp.ClientSession | None = None
        self._timeout = aiohttp.ClientTimeout(total=None, sock_connect=CONNECT_TIMEOUT_S, sock_read=READ_TIMEOUT_S)
        self.session_id: str | None = None
        #: The negotiated protocol version, from the session's stamp on each message after `initialize`.
        self.protocol_version: str | None = None
        #: Requests whose POST is in flight: the scope that aborts it, and whether it went out at 2026.
        self._in_flight: dict[RequestId, tuple[anyio.CancelScope, bool]] = {}
        #: TCP connections opened so far (a kept-alive pool opens one per session).
        self.connections_opened = 0

    def _session(self) -> aiohttp.ClientSession:
        if self._http is None:

            def opened() -> None:
                self.connections_opened += 1

            self._http = pooled_session(self._keepalive_s, opened)
        return self._http

    def _headers(self, metadata: ClientMessageMetadata | None) -> dict[str, str]:
        headers = {"accept": "application/json, text/event-stream", "content-type": "application/json"}
        if self._token:
            headers["authorization"] = f"Bearer {self._token}"
        if self.session_id:
            headers[MCP_SESSION_ID] = self.session_id
        if self.protocol_version:
            headers[MCP_PROTOCOL_VERSION_HEADER] = self.protocol_version
        if metadata is not None and metadata.headers:
            headers.update(metadata.headers)
        return headers

    # --- the write side: every message the session sends ----------------------------------------

    async def pump(self, outbound: MemoryObjectReceiveStream[SessionMessage], inbound: Reader, tg: TaskGroup) -> None:
        """POST what the session writes until it closes its write stream: a request in a task of its
        own (its answer may take a while, and others may be sent meanwhile), anything else in turn."""
        async with outbound:
            async for session_message in outbound:
                message = session_message.message
                metadata = session_message.metadata
                meta = metadata if isinstance(metadata, ClientMessageMetadata) else None
                if self._cancels(message):
                    continue
                if isinstance(message, JSONRPCRequest) and message.method == "initialize":
                    self.protocol_version = None  # the handshake negotiates it afresh
                elif meta is not None and meta.headers and MCP_PROTOCOL_VERSION_HEADER in meta.headers:
                    self.protocol_version = meta.headers[MCP_PROTOCOL_VERSION_HEADER]
                if isinstance(message, JSONRPCRequest):
                    if meta is not None and meta.resumption_token:
                        await _fail(inbound, message.id, "this transport does not resume streams", INVALID_REQUEST)
                        continue
                    scope = anyio.CancelScope()
                    superseded = self._in_flight.get(message.id)
                    if superseded is not None:  # a reused id: the old POST must not answer the new request
                        superseded[0].cancel()
                    entry = (scope, self.protocol_version in MODERN_PROTOCOL_VERSIONS)
                    self._in_flight[message.id] = entry
                    tg.start_soon(self._request, message, meta, inbound, entry)
                else:
                    try:
                        await self._post(message, meta, inbound)
                    except UNREACHABLE:  # a notification lost with the server: its next request says so
                        logger.debug("a notification was not delivered", exc_info=True)

    def _cancels(self, message: JSONRPCMessage) -> bool:
        """A `notifications/cancelled` at 2026 closes the POST it names and is not sent (closing the
        stream is the cancellation there); below 2026 the frame itself is the signal, and is POSTed."""
        if not (isinstance(message, JSONRPCNotification) and message.method == "notifications/cancelled"):
            return False
        request_id = cancelled_request_id_from_params(message.params)
        entry = self._in_flight.get(request_id) if request_id is not None else None
        if entry is None:
            return self.protocol_version in MODERN_PROTOCOL_VERSIONS
        scope, modern = entry
        if modern:
            scope.cancel()
        return modern

    async def _request(
        self,
        message: JSONRPCRequest,
        meta: ClientMessageMetadata | None,
        inbound: Reader,
        entry: tuple[anyio.CancelScope, bool],
    ) -> None:
        try:
            with entry[0]:
                await self._post(message, meta, inbound)
        except UNREACHABLE as exc:  # the request's error, where it was made: the session can close cleanly
            await _fail(inbound, message.id, self._unreachable(exc), CONNECTION_CLOSED)
        finally:
            if self._in_flight.get(message.id) is entry:
                del self._in_flight[message.id]

    def _unreachable(self, exc: BaseException) -> str:
        return f"the robot server at {self.url} is unreachable: {type(exc).__name__}: {exc}"

    async def _post(self, message: JSONRPCMessage, meta: ClientMessageMetadata | None, inbound: Reader) -> None:
        body = message.model_dump_json(by_alias=True, exclude_unset=True)
        request = message if isinstance(message, JSONRPCRequest) else None
        async with self._session().post(
            self._target, data=body, headers=self._headers(meta), allow_redirects=False, timeout=self._timeout
        ) as response:
            status = response.status
            if status == 401:
                raise ServerConnectionError(refused_sentence(self.url, self._token))
            if request is None:  # a notification or an answer to the server: nothing comes back
                await response.read()
                return
            request_id = request.id
            if status == 202:
                await response.read()
                await _fail(inbound, request_id, "server answered a request with 202 Accepted", INVALID_REQUEST)
                return
            if 300 <= status < 400:
                where = response.headers.get("location", "elsewhere")
                await response.read()
                await _fail(inbound, request_id, f"Redirect to {where} not followed", INVALID_REQUEST)
                return
            content_type = response.headers.get("content-type", "").lower()
            content = await response.read()
            if status >= 400:
                await inbound.send(SessionMessage(self._error_answer(request_id, status, content_type, content)))
                return
            if request.method == "initialize" and (session_id := response.headers.get(MCP_SESSION_ID)):
                self.session_id = session_id
            if not content_type.startswith("application/json"):
                await _fail(inbound, request_id, f"Unexpected content type: {content_type}", INVALID_REQUEST)
                return
            try:
                answer = jsonrpc_message_adapter.validate_json(content, by_name=False)
            except ValidationError as exc:
                await _fail(inbound, request_id, f"Failed to parse JSON response: {exc}", PARSE_ERROR)
                return
            await inbound.send(SessionMessage(answer))

    def _error_answer(self, request_id: RequestId, status: int, content_type: str, content: bytes) -> JSONRPCError:
        """A request's answer at an error status: the server's JSON-RPC error when it sent one, under
        this request's id; else one that the status spells (as the SDK's transport does)."""
        if content_type.startswith("application/json"):
            try:
                parsed = jsonrpc_message_adapter.validate_json(content, by_name=False)
            except ValidationError:
                parsed = None
            if isinstance(parsed, JSONRPCError):
                return JSONRPCError(jsonrpc="2.0", id=request_id, error=parsed.error)
        if status == 404:
            error = (
                ErrorData(code=METHOD_NOT_FOUND, message="Not Found")
                if self.session_id is None
                else ErrorData(code=INVALID_REQUEST, message="Session terminated")
            )
        else:
            error = ErrorData(code=INTERNAL_ERROR, message="Server returned an error response")
        return JSONRPCError(jsonrpc="2.0", id=request_id, error=error)

    async def close(self, terminate: bool) -> None:
        """End the session on the server (`DELETE`, best effort) and close the pool."""
        if self._http is None:
            return
        try:
            if terminate and self.session_id:
                with anyio.move_on_after(5):
                    async with self._http.delete(self._target, headers=self._headers(None), timeout=self._timeout):
                        pass
        except (aiohttp.ClientError, OSError):
            pass  # the server is gone already: its sessions with it
        finally:
            await self._http.close()
            self._http = None


async def _fail(inbound: Reader, request_id: RequestId, message: str, code: int) -> None:
    """Answer the request `request_id` with an error: its caller learns why and does not wait on."""
    error = JSONRPCError(jsonrpc="2.0", id=request_id, error=ErrorData(code=code, message=message))
    with contextlib.suppress(anyio.BrokenResourceError, anyio.ClosedResourceError):  # a session closing: nobody waits
        await inbound.send(SessionMessage(error))


@asynccontextmanager
async def json_http_streams(link: JsonHttpLink, *, terminate_on_close: bool = True) -> AsyncIterator[Any]:
    """The read and write streams of an MCP session over `link` (which the caller may inspect)."""
    inbound_writer, inbound = anyio.create_memory_object_stream[SessionMessage | Exception](0)
    outbound, outbound_reader = anyio.create_memory_object_stream[SessionMessage](0)
    try:
        async with inbound_writer, inbound, outbound, anyio.create_task_group() as tg:
            tg.start_soon(link.pump, outbound_reader, inbound_writer, tg)
            try:
                yield inbound, outbound
            finally:
                tg.cancel_scope.cancel()
    finally:
        with anyio.CancelScope(shield=True):
            await link.close(terminate_on_close)


@asynccontextmanager
async def json_http_client(
    url: str, token: str | None = None, *, keepalive_s: float = 15.0, terminate_on_close: bool = True
) -> AsyncIterator[Any]:
    """The read and write streams of an MCP session with the server at `url`, which answers in JSON."""
    link = JsonHttpLink(url, token, keepalive_s=keepalive_s)
    async with json_http_streams(link, terminate_on_close=terminate_on_close) as streams:
        yield streams


__all__ = ["JsonHttpLink", "json_http_client", "json_http_streams", "refused_sentence"]
