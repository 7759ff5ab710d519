"""robocog's lean MCP client, for the servers a study starts itself.

An attempt is 23 MCP requests. The SDK's `Client` serves any server: every protocol era, input
rounds, response caching, progress, sampling and elicitation callbacks, resumable streams. For each
request it stamps and dumps a model, opens an OpenTelemetry span, a request clock and a memory
stream for the answer, passes the message through a transport task, parses the answer into a
message model and validates its result twice. Against the server a study spawns for each worker
(`robocog-server` over stdio), a no-op call cost the harness about 0.4 ms of CPU that way, and about
0.2 ms through this client, of which the JSON-RPC round trip itself is about 0.12 (the
`client.stdio.*` figures of `make bench --only client`).

`LeanClient` speaks only to those servers (and to the fleets a study starts, over HTTP with JSON
answers: `json_http`), and only what the harness asks of them: the handshake, `tools/list`,
`prompts/get`, `resources/read` and `tools/call`. Each request is one JSON line (or one POST) and
its answer one parse; results are the SDK's own types (`CallToolResult` and the rest), a tool's
structured content is checked against its output schema as the SDK checks it (`output_schemas`),
and a failure is the SDK's `MCPError`: a JSON-RPC error with its code, `CONNECTION_CLOSED` when the
server is gone, `REQUEST_TIMEOUT` past a call's timeout (the server is told with
`notifications/cancelled`, as it is when the caller is cancelled).

It speaks MCP 2025-11-25 (`initialize`, then a session the server knows the client by: over HTTP its
`Mcp-Session-Id`, over stdio the connection), which robocog's server serves beside 2026-07-28; there
its event loop spends about a sixth less on a call than on a 2026-07-28 request, which carries its
protocol version and its client in every request's `_meta` and is answered with the server's own
(measured over stdio in alternating rounds: 0.42 against 0.50 ms for a no-op call, 0.54 against
0.66 ms for `look_around`). What it does not do: answer a server's requests (a ping is answered,
anything else refused: the study's servers send none), read notifications (none is asked for), or
carry on an input round (a result that asks for input fails its request, naming it). Every server a
user names (`--url`, `--server-cmd`) and every other client stays on the SDK's.
"""

from __future__ import annotations

import contextlib
import json
import logging
from collections.abc import AsyncIterator, Mapping
from contextlib import asynccontextmanager
from dataclasses import dataclass
from types import TracebackType
from typing import IO, Any, Self

import anyio
from mcp.shared.exceptions import MCPError
from mcp_types import (
    CONNECTION_CLOSED,
    INVALID_REQUEST,
    METHOD_NOT_FOUND,
    PARSE_ERROR,
    REQUEST_TIMEOUT,
    CallToolResult,
    ErrorData,
    GetPromptResult,
    Implementation,
    ListToolsResult,
    ReadResourceResult,
    RequestParamsMeta,
    Tool,
)

from robocog.agent.client.output_schemas import OutputCheck
from robocog.agent.client.protocols import Channel, Message

logger = logging.getLogger(__name__)

#: The protocol version it speaks (see the module's docstring).
PROTOCOL_VERSION = "2025-11-25"
#: How long a cancellation's notice may take to go out before the caller's cancellation goes on.
CANCEL_NOTICE_S = 2.0


@dataclass
class Handshake:
    """What the server said of itself."""

    version: str
    instructions: str | None


class LeanClient:
    """An MCP client session over `channel` (see the module's docstring). Use it as an async context
    manager: entering makes the handshake (the channel's owner closes the channel)."""

    def __init__(self, channel: Channel, *, client_info: Implementation, name: str) -> None:
        self._channel = channel
        self._name = name  # the server, as errors name it
        self._client_info = client_info.model_dump(mode="json", exclude_none=True)
        self._next_id = 0
        self._checks: dict[str, OutputCheck] = {}
        self.handshake: Handshake | None = None

    # --- the session -----------------------------------------------------------------------------

    async def __aenter__(self) -> Self:
        params = {"protocolVersion": PROTOCOL_VERSION, "capabilities": {}, "clientInfo": self._client_info}
        found = await self._request("initialize", params)
        version = found.get("protocolVersion")
        if version != PROTOCOL_VERSION:
            raise MCPError(INVALID_REQUEST, f"{self._name} answered initialize with protocol {version!r}")
        await self._channel.notify({"jsonrpc": "2.0", "method": "notifications/initialized"})
        self.handshake = Handshake(PROTOCOL_VERSION, found.get("instructions"))
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        return None

    @property
    def instructions(self) -> str | None:
        return self.handshake.instructions if self.handshake else None

    async def _request(self, method: str, params: Mapping[str, Any], timeout: float | None = None) -> dict[str, Any]:
        """The result of one request (see `MCPError` in the module's docstring)."""
        self._next_id += 1
        request_id = self._next_id
        message: Message = {"jsonrpc": "2.0", "id": request_id, "method": method}
        if params:
            message["params"] = dict(params)
        try:
            if timeout is None:
                answer = await self._channel.request(message)
            else:
                with anyio.fail_after(timeout):
                    answer = await self._channel.request(message)
        except TimeoutError:
            await self._cancel(method, request_id, f"timed out after {timeout}s")
            raise MCPError(REQUEST_TIMEOUT, f"Request {method!r} timed out") from None
        except anyio.get_cancelled_exc_class():
            await self._cancel(method, request_id, "caller cancelled")
            raise
        error = answer.get("error")
        if error is not None:
            data = ErrorData.model_validate(error) if isinstance(error, dict) else None
            raise MCPError.from_error_data(data or ErrorData(code=PARSE_ERROR, message=f"a malformed error: {error}"))
        result = answer.get("result")
        if not isinstance(result, dict):
            raise MCPError(PARSE_ERROR, f"{self._name} answered {method} without a result object")
        kind = result.get("resultType", "complete")
        if kind != "complete":
            raise MCPError(
                INVALID_REQUEST, f"{self._name} answered {method} with a {kind!r} result, which a study cannot give"
            )
        return result

    async def _cancel(self, method: str, request_id: int, reason: str) -> None:
        """Tell the server a request is abandoned (best effort, bounded); the handshake is never
        cancelled (the protocol forbids it)."""
        if method == "initialize":
            return
        params = {"requestId": request_id, "reason": reason}
        notice = {"jsonrpc": "2.0", "method": "notifications/cancelled", "params": params}
        with anyio.CancelScope(shield=True), anyio.move_on_after(CANCEL_NOTICE_S):
            try:
                await self._channel.notify(notice)
            except Exception:  # the server is gone: nothing to tell
                logger.debug("a cancellation notice was not delivered", exc_info=True)

    # --- what the harness asks -------------------------------------------------------------------

    async def list_tools(self) -> ListToolsResult:
        """Every tool, page after page; each tool's output schema is kept to check its results."""
        tools: list[Tool] = []
        cursor: str | None = None
        while True:
            page = ListToolsResult.model_validate(
                await self._request("tools/list", {"cursor": cursor} if cursor else {})
            )
            tools += page.tools
            cursor = page.next_cursor
            if not cursor:
                break
        self._checks = {t.name: OutputCheck.of(t.output_schema) for t in tools if isinstance(t.output_schema, dict)}
        return ListToolsResult(tools=tools)

    async def call_tool(
        self,
        name: str,
        arguments: dict[str, Any] | None = None,
        read_timeout_seconds: float | None = None,
        *,
        meta: RequestParamsMeta | None = None,
    ) -> CallToolResult:
        """Call a tool; a result that is not an error is checked against the tool's output schema."""
        params: dict[str, Any] = {"name": name, "arguments": arguments or {}}
        if meta:
            params["_meta"] = dict(meta)
        result = CallToolResult.model_validate(await self._request("tools/call", params, read_timeout_seconds))
        check = self._checks.get(name)
        if check is not None and not result.is_error:
            check(name, result.structured_content, present="structured_content" in result.model_fields_set)
        return result

    async def read_resource(self, uri: str) -> ReadResourceResult:
        return ReadResourceResult.model_validate(await self._request("resources/read", {"uri": str(uri)}))

    async def get_prompt(self, name: str, arguments: dict[str, str] | None = None) -> GetPromptResult:
        params: dict[str, Any] = {"name": name}
        if arguments:
            params["arguments"] = arguments
        return GetPromptResult.model_validate(await self._request("prompts/get", params))


# --- over stdio --------------------------------------------------------------------------------------


@asynccontextmanager
async def stdio_channel(
    command: list[str], env: dict[str, str], errlog: IO[str], label: str
) -> AsyncIterator[StdioChannel]:
    """A server process of the client's own (POSIX), spawned in a process group of its own; on leaving,
    its stdin is closed and it has `StdioChannel.EXIT_S` to exit before its group is ended, as the
    SDK's stdio transport does."""
    from mcp.client.stdio import get_default_environment

    process = await anyio.open_process(
        command, env=get_default_environment() | env, stderr=errlog, start_new_session=True
    )
    channel = StdioChannel(process, label)
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(channel.read)
            try:
                yield channel
            finally:
                with anyio.CancelScope(shield=True):
                    await channel.stop()
                tg.cancel_scope.cancel()
    finally:
        with anyio.CancelScope(shield=True):
            await process.aclose()


class StdioChannel:
    """A JSON-RPC message a line each way, over a server process's pipes (`stdio_channel`)."""

    EXIT_S = 2.0

    def __init__(self, process: anyio.abc.Process, label: str) -> None:
        self._process = process
        self._label = label
        self._pending: dict[Any, anyio.Event] = {}
        self._answers: dict[Any, Message] = {}
        self._gone: str | None = None  # why the server cannot be reached any more

    async def request(self, message: Message) -> Message:
        request_id = message["id"]
        if self._gone is not None:
            return _closed(request_id, self._gone)
        answered = self._pending[request_id] = anyio.Event()
        try:
            await self._write(message)
            await answered.wait()
            return self._answers.pop(request_id)
        except (anyio.BrokenResourceError, anyio.ClosedResourceError, OSError) as exc:
            return _closed(request_id, self._gone or f"{self._label} cannot be written to: {exc}")
        finally:
            self._pending.pop(request_id, None)
            self._answers.pop(request_id, None)

    async def notify(self, message: Message) -> None:
        if self._gone is None:
            await self._write(message)

    async def _write(self, message: Message) -> None:
        stdin = self._process.stdin
        assert stdin is not None
        # One write of the whole line: messages written at once never interleave (the pipe's
        # buffer takes each in one piece; `send` then waits for it to drain).
        await stdin.send(json.dumps(message, separators=(",", ":"), ensure_ascii=False).encode() + b"\n")

    async def read(self) -> None:
        """Take the server's lines until its output ends; then every request waiting, and every one
        made later, is answered `CONNECTION_CLOSED`."""
        stdout = self._process.stdout
        assert stdout is not None
        parts: list[bytes] = []
        try:
            while True:
                chunk = await stdout.receive(1 << 20)
                while (end := chunk.find(b"\n")) >= 0:
                    parts.append(chunk[:end])
                    line, parts, chunk = b"".join(parts), [], chunk[end + 1 :]
                    if line.strip():
                        await self._take(line)
                if chunk:
                    parts.append(chunk)
        except (anyio.EndOfStream, anyio.ClosedResourceError, anyio.BrokenResourceError, OSError):
            pass
        finally:
            self._gone = "Connection closed"  # the SDK's words for a server whose output ended
            for request_id, answered in list(self._pending.items()):
                self._answers[request_id] = _closed(request_id, self._gone)
                answered.set()

    async def _take(self, line: bytes) -> None:
        try:
            message = json.loads(line)
        except ValueError:
            logger.warning("%s wrote a line that is not JSON: %.200r", self._label, line)
            return
        if not isinstance(message, dict):
            return
        if "method" not in message:  # an answer
            request_id = message.get("id")
            answered = self._pending.get(request_id)
            if answered is not None:
                self._answers[request_id] = message
                answered.set()
            return
        if "id" in message:  # the server asks something: a ping is answered, anything else refused
            answer: Message = {"jsonrpc": "2.0", "id": message["id"]}
            if message["method"] == "ping":
                answer["result"] = {}
            else:
                answer["error"] = {"code": METHOD_NOT_FOUND, "message": "robocog's study client takes no requests"}
            with contextlib.suppress(anyio.BrokenResourceError, anyio.ClosedResourceError, OSError):
                await self._write(answer)

    async def stop(self) -> None:
        """Close the server's stdin, give it `EXIT_S` to exit, then end its process group."""
        from mcp.os.posix.utilities import terminate_posix_process_tree

        process = self._process
        if process.stdin is not None:
            with contextlib.suppress(anyio.BrokenResourceError, anyio.ClosedResourceError, OSError):
                await process.stdin.aclose()
        with anyio.move_on_after(self.EXIT_S):
            await process.wait()
        if process.returncode is None:
            await terminate_posix_process_tree(process, self.EXIT_S)
            with anyio.move_on_after(self.EXIT_S):
                await process.wait()


def _closed(request_id: Any, reason: str) -> Message:
    """The answer of a request whose server cannot be reached."""
    return {"jsonrpc": "2.0", "id": request_id, "error": {"code": CONNECTION_CLOSED, "message": reason}}
