"""The lean client's channel over streamable HTTP, for a server that answers every POST with one JSON
body: the fleets a study starts itself (`robocog-server --json-response`, on this machine's loopback).

httpx (`httpx2`, the MCP SDK's own HTTP client) does the HTTP: it writes each POST, parses each answer
and keeps one connection alive for the attempt (its pool drops a connection idle past `keepalive_s`,
the client's 60 s, under the server's 75 s, and one the server closed before it is written on). What
this channel adds is MCP's part, as the SDK's streamable HTTP transport does it: the session id from
`initialize`'s answer on every later request, with the negotiated `MCP-Protocol-Version` and the bearer
token; a `202 Accepted` or an error status as the request's JSON-RPC error (the server's own error
body when it sent one); the SDK's timeouts (`CONNECT_TIMEOUT_S`, `READ_TIMEOUT_S`); and a `DELETE` of
the session when it closes, which frees the fleet's robot at once. A `401` is `ServerConnectionError`
with the same sentence as robocog's SDK path. A POST is never sent twice (httpx retries nothing unless
asked: a POST could have reached the server).

What it does better for a study: a server that cannot be reached, hangs up or never answers fails
the request it was sent, as that request's error (`CONNECTION_CLOSED`, naming the error), where the
SDK's transport ends the whole session from its task group and cancels whatever the caller was doing.
The episode loop then reports the server's failure, the harness records the attempt as broken and
reconnects, and a fleet that died is started again (`Runner.worker`, `Fleets.ensure`).

What it does not do, because the fleets never need it: TLS (the fleets listen on loopback; an
`https://` URL is refused), read an event stream (an answer that is not JSON fails its request, naming
the content type), follow a redirect (it fails its request, naming the location), resume a stream, or
open the GET stream for notifications no worker subscribes to. Every other server, and every URL a
user gives, goes through the SDK's client (`connection._http_transport`).
"""

from __future__ import annotations

import functools
import json
import logging
import ssl
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any
from urllib.parse import urlsplit

import anyio
import httpx2
from mcp.shared.inbound import MCP_PROTOCOL_VERSION_HEADER
from mcp_types import CONNECTION_CLOSED, INTERNAL_ERROR, INVALID_REQUEST, METHOD_NOT_FOUND, PARSE_ERROR

from robocog.agent.client.protocols import Message
from robocog.shared.errors import ServerConnectionError

MCP_SESSION_ID = "mcp-session-id"
#: The SDK's own timeouts for streamable HTTP (`connection._http_transport`): connecting, and reading.
CONNECT_TIMEOUT_S, READ_TIMEOUT_S = 30.0, 300.0
#: How long closing waits for the session's `DELETE`.
DELETE_S = 5.0

logger = logging.getLogger(__name__)


@functools.cache
def tls_context() -> ssl.SSLContext:
    """httpx's default TLS context (its CA bundle), made once per process and shared by every client
    robocog makes: httpx makes one per client otherwise, about 45 ms of CPU at every connection (a
    study of 64 workers makes 64 at its start). The fleets' channel takes plain HTTP and never uses it."""
    return httpx2.create_ssl_context()


def refused_sentence(url: str, token: str | None) -> str:
    """What a `401` means to the person running the client (the SDK path says the same)."""
    given = "the bearer token in $ROBOCOG_AUTH_TOKEN was refused" if token else "it needs a bearer token"
    return (
        f"the robot server at {url} refused the connection: {given} "
        "(set ROBOCOG_AUTH_TOKEN to the server's --auth-token)"
    )


class HttpChannel:
    """One MCP session over streamable HTTP with JSON answers (a `protocols.Channel`): POSTs through
    one httpx client, whose pool keeps the connection alive (one, unless requests overlap)."""

    def __init__(self, url: str, token: str | None, *, keepalive_s: float) -> None:
        if urlsplit(url).scheme.lower() != "http":
            raise ValueError(f"{url}: the lean client's channel takes http:// URLs only")
        self.url = url
        self._token = token
        headers = {"accept": "application/json, text/event-stream", "content-type": "application/json"}
        if token:
            headers["authorization"] = f"Bearer {token}"
        self._http = httpx2.AsyncClient(
            headers=headers,
            timeout=httpx2.Timeout(CONNECT_TIMEOUT_S, read=READ_TIMEOUT_S),
            limits=httpx2.Limits(keepalive_expiry=keepalive_s),
            verify=tls_context(),
            trust_env=False,  # a fleet of the study's own, on loopback: no proxy from the environment
        )
        self.session_id: str | None = None
        #: The protocol version `initialize` negotiated, sent with every later message.
        self.protocol_version: str | None = None

    def _session_headers(self) -> dict[str, str]:
        headers: dict[str, str] = {}
        if self.session_id:
            headers[MCP_SESSION_ID] = self.session_id
        if self.protocol_version:
            headers[MCP_PROTOCOL_VERSION_HEADER] = self.protocol_version
        return headers

    async def _post(self, message: Message) -> httpx2.Response:
        response = await self._http.post(self.url, content=_dumps(message), headers=self._session_headers())
        if response.status_code == 401:
            raise ServerConnectionError(refused_sentence(self.url, self._token))
        return response

    async def request(self, message: Message) -> Message:
        """POST a request; its answer, or the error that stands for one (see the module's docstring)."""
        request_id = message["id"]
        initialize = message["method"] == "initialize"
        if initialize:  # the handshake negotiates a session and a version afresh
            self.session_id = self.protocol_version = None
        try:
            response = await self._post(message)
        except httpx2.RequestError as exc:  # the request's error, where it was made: the session goes on
            return _error(request_id, CONNECTION_CLOSED, self._unreachable(exc))
        status, content = response.status_code, response.content
        content_type = response.headers.get("content-type", "").lower()
        if status == 202:
            return _error(request_id, INVALID_REQUEST, "server answered a request with 202 Accepted")
        if 300 <= status < 400:
            where = response.headers.get("location", "elsewhere")
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
            self.session_id = response.headers.get(MCP_SESSION_ID)
            version = answer["result"].get("protocolVersion") if isinstance(answer["result"], dict) else None
            self.protocol_version = version if isinstance(version, str) else None
        return answer

    async def notify(self, message: Message) -> None:
        """POST a notification (best effort: one lost with the server, its next request says so)."""
        try:
            await self._post(message)
        except httpx2.RequestError:
            logger.debug("a notification was not delivered", exc_info=True)

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
                with anyio.move_on_after(DELETE_S):
                    await self._http.delete(self.url, headers=self._session_headers())
        except httpx2.RequestError:
            pass  # the server is gone already: its sessions with it
        finally:
            await self._http.aclose()


def _dumps(message: Message) -> bytes:
    return json.dumps(message, separators=(",", ":"), ensure_ascii=False).encode()


def _error(request_id: Any, code: int, message: str) -> Message:
    """The answer of a request that failed on its way: its caller learns why and does not wait on."""
    return {"jsonrpc": "2.0", "id": request_id, "error": {"code": code, "message": message}}


@asynccontextmanager
async def http_channel(
    url: str, token: str | None = None, *, keepalive_s: float = 15.0, terminate_on_close: bool = True
) -> AsyncIterator[HttpChannel]:
    """A channel to the server at `url`, which answers in JSON; its session deleted on leaving."""
    channel = HttpChannel(url, token, keepalive_s=keepalive_s)
    try:
        yield channel
    finally:
        with anyio.CancelScope(shield=True):
            await channel.close(terminate_on_close)


__all__ = ["HttpChannel", "http_channel", "refused_sentence"]
