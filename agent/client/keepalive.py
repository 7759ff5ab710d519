"""One TCP connection for a whole attempt over streamable HTTP, where the MCP SDK opened one per call.

The SDK reads a request's answer from the POST's SSE stream and closes the response as soon as the
answer's event has arrived (`mcp/client/streamable_http.py`, `_handle_sse_response`: `await
response.aclose()` after the completing event), before the few bytes that end the stream (the last
chunk of the chunked body). httpcore reuses a connection only when both sides of the exchange are
done (`httpcore2/_async/http11.py`, `_response_closed`), so it closed every connection, and every
call paid for a new one (a `202 Accepted`, unread, did the same). `KeepAliveTransport` reads what
is left of a POST's answer when it is closed, for at most `DRAIN_S` and `DRAIN_BYTES`: the stream's
end follows its last event at once, so the connection goes back to the pool. A stream that does not
end by then is closed as before (its connection is not reused: nothing is lost but the reuse). GET
streams (the server's notifications) are left alone: they are meant to stay open.

    transport = KeepAliveTransport(httpx2.AsyncHTTPTransport(limits=httpx2.Limits(keepalive_expiry=60)))
    client = httpx2.AsyncClient(transport=transport)
"""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import httpx2

#: How long, and how many bytes, closing a POST's answer waits for the rest of its stream.
DRAIN_S = 0.25
DRAIN_BYTES = 64 * 1024


class KeepAliveTransport(httpx2.AsyncBaseTransport):
    """`inner`, with every POST's (and DELETE's) answer read to its end when it is closed."""

    def __init__(self, inner: httpx2.AsyncBaseTransport) -> None:
        self._inner = inner

    async def handle_async_request(self, request: httpx2.Request) -> httpx2.Response:
        response = await self._inner.handle_async_request(request)
        if request.method != "GET" and isinstance(response.stream, httpx2.AsyncByteStream):
            response.stream = _DrainOnClose(response.stream)
        return response

    async def aclose(self) -> None:
        await self._inner.aclose()


class _DrainOnClose(httpx2.AsyncByteStream):
    """A response body that, closed early, first reads what is left of it (within the limits above).
    It keeps one iterator over the body, so that the reading resumes where the reader stopped."""

    def __init__(self, inner: httpx2.AsyncByteStream) -> None:
        self._inner = inner
        self._parts = aiter(inner)

    async def __aiter__(self) -> AsyncIterator[bytes]:
        async for part in self._parts:  # a reader that breaks off leaves `_parts` where it was
            yield part

    async def aclose(self) -> None:
        try:
            with anyio.move_on_after(DRAIN_S):
                left = DRAIN_BYTES
                async for part in self._parts:
                    left -= len(part)
                    if left < 0:
                        break
        except Exception:
            pass
        finally:
            with anyio.CancelScope(shield=True):
                await self._inner.aclose()


__all__ = ["DRAIN_BYTES", "DRAIN_S", "KeepAliveTransport"]
