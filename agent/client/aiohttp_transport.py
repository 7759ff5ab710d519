"""The MCP SDK's HTTP client (httpx) sending its requests through aiohttp, for plain-HTTP servers.

The SDK speaks streamable HTTP through an `httpx2.AsyncClient`. Under it, httpcore and h11 parse
and write HTTP/1.1 in Python: 0.68 ms of CPU per request on this machine against 0.15 ms for aiohttp,
whose parser is compiled (llhttp), for the same POST over a kept-alive loopback connection. A study on
fleets makes about 23 requests per attempt, so the harness spent 81 ms of CPU per attempt over HTTP
against 43 ms over stdio. `AiohttpTransport` is an httpx transport, so the SDK, its timeouts, robocog's
event hooks and the draining of `keepalive.py` stay as they were: only the bytes go through aiohttp.

It maps aiohttp's failures to httpx's (a refused connection is `ConnectError`, a read that times out
`ReadTimeout`, a server that hangs up mid-answer `RemoteProtocolError`), so the SDK and robocog's
messages read as before. It decompresses nothing (httpx decodes a compressed body, as before) and
sends httpx's headers only (no `User-Agent: aiohttp`). It serves `http://` URLs: `https://` stays on
httpx's own transport, with its certificate store.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from typing import Any

import aiohttp
import httpx2
from aiohttp.http_exceptions import HttpProcessingError
from yarl import URL

#: Headers aiohttp computes from the body itself (httpx has set them for the same body).
_COMPUTED = frozenset({"content-length", "transfer-encoding"})


def pooled_session(keepalive_s: float, opened: Callable[[], None]) -> aiohttp.ClientSession:
    """An aiohttp session whose pool keeps connections alive for `keepalive_s`, calling `opened` for
    every TCP connection it opens. It sends only the headers it is given (no `User-Agent: aiohttp`, no
    `Accept-Encoding`), keeps no cookies and decompresses nothing."""

    async def counted(*_: object) -> None:
        opened()

    tracing = aiohttp.TraceConfig()
    tracing.on_connection_create_end.append(counted)
    return aiohttp.ClientSession(
        connector=aiohttp.TCPConnector(limit=0, keepalive_timeout=keepalive_s),
        cookie_jar=aiohttp.DummyCookieJar(),
        auto_decompress=False,
        skip_auto_headers=("User-Agent", "Accept", "Accept-Encoding", "Content-Type"),
        trace_configs=[tracing],
    )


class AiohttpTransport(httpx2.AsyncBaseTransport):
    """httpx requests sent by one aiohttp session (its pool keeps connections alive for
    `keepalive_s`); the session is made on the first request, in the event loop that sends it."""

    def __init__(self, *, keepalive_s: float = 15.0) -> None:
        self._keepalive_s = keepalive_s
        self._session: aiohttp.ClientSession | None = None
        #: TCP connections opened so far (for tests and benches: a kept-alive pool opens one).
        self.connections_opened = 0

    def _open(self) -> aiohttp.ClientSession:
        if self._session is None:

            def opened() -> None:
                self.connections_opened += 1

            self._session = pooled_session(self._keepalive_s, opened)
        return self._session

    async def handle_async_request(self, request: httpx2.Request) -> httpx2.Response:
        timeout = request.extensions.get("timeout", {})
        headers = [(k, v) for k, v in request.headers.multi_items() if k.lower() not in _COMPUTED]
        try:
            body = await request.aread()
            response = await self._open().request(
                request.method,
                URL(str(request.url), encoded=True),
                headers=headers,
                data=body or None,
                allow_redirects=False,  # httpx follows redirects itself, when asked
                timeout=aiohttp.ClientTimeout(
                    total=None, sock_connect=timeout.get("connect"), sock_read=timeout.get("read")
                ),
            )
        except Exception as exc:
            raise _as_httpx(exc, request, connecting=True) from exc
        return httpx2.Response(
            response.status,
            headers=list(response.raw_headers),
            stream=_Body(response, request),
            request=request,
            extensions={"http_version": b"HTTP/1.1", "reason_phrase": (response.reason or "").encode()},
        )

    async def aclose(self) -> None:
        if self._session is not None:
            await self._session.close()
            self._session = None


class _Body(httpx2.AsyncByteStream):
    """An aiohttp response's body, read as it arrives; closed, its connection goes back to the pool
    when the body was read to its end (aiohttp closes it otherwise)."""

    def __init__(self, response: aiohttp.ClientResponse, request: httpx2.Request) -> None:
        self._response = response
        self._request = request

    async def __aiter__(self) -> AsyncIterator[bytes]:
        try:
            async for chunk in self._response.content.iter_any():
                yield chunk
        except Exception as exc:
            raise _as_httpx(exc, self._request) from exc

    async def aclose(self) -> None:
        self._response.release()


def _as_httpx(exc: BaseException, request: httpx2.Request, *, connecting: bool = False) -> BaseException:
    """aiohttp's (or asyncio's) failure as the httpx error the SDK and robocog expect; anything
    else as it is (a cancellation, say)."""
    kind: Callable[..., httpx2.TransportError]
    if isinstance(exc, aiohttp.ConnectionTimeoutError):
        kind = httpx2.ConnectTimeout
    elif isinstance(exc, aiohttp.ServerTimeoutError | asyncio.TimeoutError):
        kind = httpx2.ReadTimeout
    elif isinstance(exc, aiohttp.ClientConnectorError):
        kind = httpx2.ConnectError
    elif isinstance(  # a malformed answer is an HttpProcessingError while its body is read
        exc,
        aiohttp.ServerDisconnectedError
        | aiohttp.ClientPayloadError
        | aiohttp.ClientResponseError
        | HttpProcessingError,
    ):
        kind = httpx2.RemoteProtocolError
    elif isinstance(exc, aiohttp.ClientOSError | ConnectionError):
        kind = httpx2.ConnectError if connecting else httpx2.ReadError
    elif isinstance(exc, aiohttp.ClientError):
        kind = httpx2.NetworkError
    else:
        return exc
    return kind(str(exc) or type(exc).__name__, request=request)


def transport_for(url: str, **httpx_options: Any) -> httpx2.AsyncBaseTransport:
    """aiohttp's for a plain-HTTP `url`, httpx's own (with `httpx_options`) for any other."""
    if url.lower().startswith("http://"):
        keepalive = httpx_options.get("limits", httpx2.Limits()).keepalive_expiry
        return AiohttpTransport(keepalive_s=15.0 if keepalive is None else keepalive)
    return httpx2.AsyncHTTPTransport(**httpx_options)


__all__ = ["AiohttpTransport", "pooled_session", "transport_for"]
