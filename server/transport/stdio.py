"""MCP over stdio, read and written on the event loop.

The SDK's `stdio_server` reads each line of stdin and writes and flushes each message on a worker
thread (`anyio.wrap_file`): three hops between threads per call, a fifth of the server's CPU on a
cheap tool call. Here stdin and stdout are the event loop's own pipe transports (`connect_read_pipe`,
`connect_write_pipe`), handed to the SDK's `stdio_server` as its streams, so its framing and parsing
stay the SDK's.

Like the SDK, the wire is served from private duplicates of descriptors 0 and 1 while fd 0 reads the
null device and fd 1 goes to stderr, so nothing else in the process (PyBullet's C prints, a child)
can write into the protocol. Where the loop cannot watch the descriptors (stdin a regular file, not
POSIX), the SDK's own transport serves instead.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import stat
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any, cast

from mcp.server.mcpserver import MCPServer
from mcp.server.stdio import stdio_server

from robocog.server import compat
from robocog.server.world.sim import SHUTTING_DOWN

#: The longest line (one JSON-RPC message) read from stdin; the SDK's own transport has no limit.
LINE_LIMIT = 256 * 1024 * 1024


class _Lines:
    """The lines of stdin as text (what `stdio_server` iterates over)."""

    def __init__(self, reader: asyncio.StreamReader) -> None:
        self._reader = reader

    def __aiter__(self) -> _Lines:
        return self

    async def __anext__(self) -> str:
        line = await self._reader.readline()
        if not line:  # the client has gone: a running action stops at its next check, and the server exits
            SHUTTING_DOWN.set()
            raise StopAsyncIteration
        return line.decode("utf-8", errors="replace")


class _Writer:
    """stdout as `stdio_server` writes to it: a message, then a flush (waits while the pipe is full)."""

    def __init__(self, writer: asyncio.StreamWriter) -> None:
        self._writer = writer

    async def write(self, text: str) -> None:
        self._writer.write(text.encode("utf-8"))

    async def flush(self) -> None:
        await self._writer.drain()


@asynccontextmanager
async def _divert(fd: int, to: int) -> AsyncIterator[int]:
    """A private duplicate of `fd` (the wire) while `fd` itself points at `to`; restored after."""
    import fcntl

    wire = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 3)
    try:
        os.dup2(to, fd)
        try:
            yield wire
        finally:
            os.dup2(wire, fd)
    finally:
        os.close(wire)


def _watchable(fd: int) -> bool:
    """Whether the event loop can watch `fd`: a pipe, a socket or a terminal (not a regular file, nor
    another device such as /dev/null)."""
    try:
        mode = os.fstat(fd).st_mode
    except OSError:
        return False
    # A character device only when it is a terminal: epoll refuses /dev/null (EPERM), and uvloop's libuv
    # aborts the process on that refusal (a server started with stdin from the null device died so).
    return stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode) or (stat.S_ISCHR(mode) and os.isatty(fd))


@asynccontextmanager
async def _loop_pipes() -> AsyncIterator[tuple[_Lines, _Writer] | None]:
    """stdin and stdout on the running loop, or None where the loop cannot watch them."""
    if sys.platform == "win32" or not (_watchable(0) and _watchable(1)):
        yield None
        return
    loop = asyncio.get_running_loop()
    null = os.open(os.devnull, os.O_RDONLY)
    try:
        async with _divert(0, null) as wire_in, _divert(1, 2) as wire_out:
            reader = asyncio.StreamReader(limit=LINE_LIMIT)
            source = os.fdopen(wire_in, "rb", buffering=0, closefd=False)
            sink = os.fdopen(wire_out, "wb", buffering=0, closefd=False)
            read, _ = await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), source)
            write, protocol = await loop.connect_write_pipe(asyncio.streams.FlowControlMixin, sink)
            writer = asyncio.StreamWriter(write, protocol, None, loop)
            try:
                yield _Lines(reader), _Writer(writer)
            finally:
                read.close()
                with contextlib.suppress(OSError, ConnectionError):
                    await writer.drain()
                write.close()
                for fd in (wire_in, wire_out):  # handed back to their owners as they were
                    with contextlib.suppress(OSError):
                        os.set_blocking(fd, True)
    finally:
        os.close(null)


async def serve_stdio(server: MCPServer[Any]) -> None:
    """Serve `server` over this process's stdin and stdout until stdin ends."""
    lowlevel = compat.lowlevel(server)
    async with _loop_pipes() as pipes:
        streams = stdio_server() if pipes is None else stdio_server(cast(Any, pipes[0]), cast(Any, pipes[1]))
        async with streams as (read_stream, write_stream):
            await lowlevel.run(read_stream, write_stream, lowlevel.create_initialization_options())
    SHUTTING_DOWN.set()  # stdin has ended (also on the SDK's own transport): nothing more is to run
