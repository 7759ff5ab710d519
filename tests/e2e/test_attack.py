"""Attacks on real `robocog-server` processes: many HTTP clients at once, `kill -9` during end_task,
and lines on the stdio stream that are not proper requests.

(Authentication and the session cap have their tests with the HTTP server's own.)
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import anyio
import pytest
from mcp import Client

from tests.helpers import http_server, server_command, server_env

pytestmark = pytest.mark.anyio

#: Longer than this without an answer, the server is hung.
ANSWER_TIMEOUT_S = 60.0


class RawStdioServer:
    """`robocog-server` over stdio, spoken to in raw JSON-RPC lines (its pid at hand, to kill it)."""

    def __init__(self, *args: str, log: Path) -> None:
        self.log = log.open("ab")
        self.proc = subprocess.Popen(
            [*server_command(), *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log, env=server_env()
        )
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.fd = self.proc.stdout.fileno()
        self.buffer = b""
        self.next_id = 0
        info = {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "attack", "version": "1"}}
        self.answer(self.send("initialize", info))
        self.write(json.dumps({"jsonrpc": "2.0", "method": "notifications/initialized"}).encode())

    def write(self, line: bytes) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + b"\n")
        self.proc.stdin.flush()

    def send(self, method: str, params: dict[str, Any]) -> int:
        self.next_id += 1
        self.write(json.dumps({"jsonrpc": "2.0", "id": self.next_id, "method": method, "params": params}).encode())
        return self.next_id

    def answer(self, request_id: int) -> dict[str, Any]:
        """The response to `request_id` (notifications and other responses on the way are skipped)."""
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        while True:
            while b"\n" not in self.buffer:
                remaining = deadline - time.monotonic()
                assert remaining > 0 and select.select([self.fd], [], [], remaining)[0], f"no answer to {request_id}"
                chunk = os.read(self.fd, 1 << 20)
                assert chunk, "the server's stdout closed"
                self.buffer += chunk
            line, self.buffer = self.buffer.split(b"\n", 1)
            message = json.loads(line) if line.strip() else None
            if isinstance(message, dict) and message.get("id") == request_id and "method" not in message:
                return message

    def call(self, tool: str, **arguments: Any) -> dict[str, Any]:
        """A tool call that must succeed; its structured content."""
        answer = self.answer(self.send("tools/call", {"name": tool, "arguments": arguments}))
        result = answer.get("result", {})
        assert not result.get("isError") and "structuredContent" in result, answer
        return dict(result["structuredContent"])

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
        self.proc.wait(timeout=30)
        self.log.close()


# --- kill -9 ---------------------------------------------------------------------------------------------


def test_every_acknowledged_end_task_survives_kill_9_and_a_retry_adds_no_duplicate(tmp_path: Path) -> None:
    """Episodes ended one after another, each acknowledged; then one more end_task is sent and the
    server is killed with SIGKILL before it can answer. A new server on the same --data-dir finds
    every acknowledged record, once; retrying the unacknowledged one (same episode id) leaves one
    record of it, not two."""
    data = str(tmp_path / "memory")
    run = uuid.uuid4().hex[:8]
    server = RawStdioServer("--profile", "eval", "--data-dir", data, log=tmp_path / "server.log")
    acknowledged: list[str] = []
    try:
        for i in range(6):
            server.call("begin_task", task_id="T1", episode_id=f"{run}-{i}")
            description = f"Durability check {run}: episode {i}."
            ended = server.call("end_task", status="success", description=description, summary=f"summary {i}")
            assert ended["record_id"], ended
            acknowledged.append(description)
        server.call("begin_task", task_id="T1", episode_id=f"{run}-last")
        in_flight = f"Durability check {run}: the episode killed while it ended."
        arguments = {"status": "failure", "description": in_flight, "summary": "killed"}
        server.send("tools/call", {"name": "end_task", "arguments": arguments})
        server.proc.send_signal(signal.SIGKILL)
        assert server.proc.wait(timeout=30) == -signal.SIGKILL
    finally:
        server.close()

    def stored(server: RawStdioServer) -> list[str]:
        found = server.call("search_memory", query=f"Durability check {run}", k=20)
        return [r["task_description"] for r in found["results"]]

    server = RawStdioServer("--profile", "eval", "--data-dir", data, log=tmp_path / "server.log")
    try:
        after_kill = stored(server)
        for description in acknowledged:
            assert after_kill.count(description) == 1, (description, after_kill)
        assert set(after_kill) <= {*acknowledged, in_flight}, after_kill
        # The client never heard back, so it retries the attempt under the same episode id.
        server.call("begin_task", task_id="T1", episode_id=f"{run}-last")
        server.call("end_task", **arguments)
        after_retry = stored(server)
        assert after_retry.count(in_flight) == 1, after_retry
        assert sorted(after_retry) == sorted([*acknowledged, in_flight])
    finally:
        server.close()


# --- lines that are not proper requests ------------------------------------------------------------------


#: Each followed by a ping, which must be answered: not JSON, not JSON-RPC, params of the wrong
#: shape, invalid UTF-8, NaN, nesting 100,000 deep, a number of 100,000 digits, a 10 MB argument.
BAD_LINES = (
    b"{",
    b"\x00\x01\x02\xff",
    b"[1, 2, 3]",
    b'{"jsonrpc": "2.0", "id": {"a": 1}, "method": "tools/list"}',
    b'{"jsonrpc": "2.0", "id": "p1", "method": "tools/call", "params": [1, 2]}',
    b'{"jsonrpc": "2.0", "id": "p2", "method": "no/such/method", "params": {}}',
    b'{"jsonrpc": "2.0", "id": "p3", "method": "tools/call", "params": {"name": "grab", "arguments": {"object": NaN}}}',
    b'{"jsonrpc": "2.0", "id": "p4", "method": "tools/call", "params": {"name": "grab", "arguments": '
    b'{"object": "\xff"}}}',
    b'{"jsonrpc": "2.0", "id": "p5", "method": "tools/call", "params": ' + b"[" * 100_000 + b"]" * 100_000 + b"}",
    b'{"jsonrpc": "2.0", "id": "p6", "method": "tools/call", "params": {"name": "grab", "arguments": {"object": 1'
    + b"0" * 100_000
    + b"}}}",
    b'{"jsonrpc": "2.0", "id": "p7", "method": "tools/call", "params": {"name": "search_memory", "arguments": '
    + b'{"query": "'
    + b"x" * 10_000_000
    + b'"}}}',
)


def test_bad_lines_on_stdio_leave_a_server_that_answers_and_a_world_intact(tmp_path: Path) -> None:
    server = RawStdioServer("--profile", "eval", "--data-dir", str(tmp_path / "memory"), log=tmp_path / "server.log")
    try:
        before = server.call("look_around")
        for line in BAD_LINES:
            server.write(line)
            assert "result" in server.answer(server.send("ping", {})), line[:80]
        assert server.proc.poll() is None
        assert server.call("look_around") == before
        server.call("move_to", location="Kitchen Table")
        assert server.call("grab", object="mug")["holding"] == "mug"
    finally:
        server.close()
    assert "Traceback" not in (tmp_path / "server.log").read_text(errors="replace")


# --- many HTTP clients at once -----------------------------------------------------------------------------


@pytest.fixture
def http_url(tmp_path: Path) -> Iterator[str]:
    """`robocog-server --transport http --profile eval` on a free loopback port; its /mcp URL."""
    with http_server(tmp_path / "http.log", "--profile", "eval", "--data-dir", str(tmp_path / "memory")) as url:
        yield url


async def test_32_http_clients_at_once_all_get_answers(http_url: str) -> None:
    """32 sessions at once, each reading the world through read-only tools and resources (acting is
    for the one session that holds the robot): every call answered, none an error."""
    async with Client(http_url) as first:
        await first.call_tool("look_around", {})  # waits for the world
    errors: list[str] = []
    answered: list[int] = []

    async def one(index: int) -> None:
        try:
            async with Client(http_url) as client:
                looked = await client.call_tool("look_around", {})
                pad = await client.call_tool("view_scratchpad", {})
                state = await client.read_resource("robocog://world/state", cache_mode="bypass")
                errors.extend(f"client {index}: {r.content}" for r in (looked, pad) if r.is_error)
                assert looked.structured_content is not None
                assert json.loads(getattr(state.contents[0], "text", "{}"))["robot"]["location"]
                answered.append(index)
        except Exception as exc:  # boundary: every failure of a client is reported below
            errors.append(f"client {index}: {type(exc).__name__}: {exc}")

    async with anyio.create_task_group() as tg:
        for index in range(32):
            tg.start_soon(one, index)
    assert errors == []
    assert sorted(answered) == list(range(32))
