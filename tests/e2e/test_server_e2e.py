"""End to end: a real `robocog-server` process, over stdio and over streamable HTTP."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp_types import CallToolResult

from robocog.shared.protocol import DRIVER_META_KEY
from tests.helpers import T1, T1_SEQUENCE, T2, T2_SEQUENCE, action_args, http_server, server_command, stdio_params

pytestmark = pytest.mark.anyio


async def run_t1_then_t2(client: Client) -> None:
    meta: dict[str, Any] | None = None  # over HTTP without a session: the driver id the server issued

    async def call(tool: str, arguments: dict[str, Any]) -> CallToolResult:
        nonlocal meta
        result = await client.call_tool(tool, arguments, meta=meta)  # type: ignore[arg-type]
        issued = (result.meta or {}).get(DRIVER_META_KEY)
        meta = {DRIVER_META_KEY: issued} if issued else meta
        return result

    for task_id, sequence, prompt in (
        ("T1", T1_SEQUENCE, T1),
        ("T2", T2_SEQUENCE, T2),
    ):
        before = await call("check_task", {"task_id": task_id})
        assert before.structured_content is not None and before.structured_content["success"] is False
        for action in sequence:
            result = await call(action[0], action_args(action))
            assert not result.is_error, result.content
        await call("end_task", {"status": "success", "description": prompt, "summary": "done"})
        after = await call("check_task", {"task_id": task_id})
        assert after.structured_content is not None and after.structured_content["success"] is True, after.content


async def test_t1_then_t2_over_stdio(tmp_path: Path) -> None:
    async with Client(stdio_params("--profile", "eval", "--data-dir", str(tmp_path))) as client:
        await run_t1_then_t2(client)


async def test_progress_goes_only_to_a_caller_that_asked_for_it(tmp_path: Path) -> None:
    """Over a real transport a progress token in the call's _meta asks for progress; a call without
    one gets no progress notification (the server does not even build them)."""
    arrived: list[Any] = []

    async def messages(message: Any) -> None:
        arrived.append(message)

    async def on_progress(progress: float, total: float | None, message: str | None) -> None:
        updates.append(progress)

    updates: list[float] = []
    params = stdio_params("--profile", "eval", "--data-dir", str(tmp_path))
    async with Client(params, message_handler=messages) as client:
        quiet = await client.call_tool("move_to", {"location": "Kitchen Shelf"})
        assert not quiet.is_error and updates == []
        assert not [m for m in arrived if "Progress" in type(getattr(m, "root", m)).__name__], arrived
        heard = await client.call_tool("move_to", {"location": "Kitchen Table"}, progress_callback=on_progress)
        assert not heard.is_error and updates and updates == list(range(1, len(updates) + 1)), updates


@pytest.fixture
def http_url(tmp_path: Path) -> Iterator[str]:
    with http_server(tmp_path / "server.log", "--profile", "eval", "--data-dir", str(tmp_path / "memory")) as url:
        yield url


async def test_t1_then_t2_over_http(http_url: str) -> None:
    async with Client(http_url) as client:
        await run_t1_then_t2(client)


async def test_memory_persists_across_a_restart_and_namespaces_stay_apart(tmp_path: Path) -> None:
    data = str(tmp_path / "memory")
    async with Client(stdio_params("--data-dir", data, "--memory-namespace", "trial-1")) as client:
        await client.call_tool("end_task", {"status": "success", "description": T1, "summary": "ok"})
        await client.call_tool("end_task", {"status": "failure", "description": "Open the window.", "summary": "no"})
    async with Client(stdio_params("--data-dir", data, "--memory-namespace", "trial-1")) as client:
        found = await client.call_tool("search_memory", {"query": "put the items away on the shelf"})
        assert found.structured_content is not None
        results = found.structured_content["results"]
        assert len(results) == 2
        assert results[0]["task_description"] == T1
    async with Client(stdio_params("--data-dir", data, "--memory-namespace", "trial-2")) as client:
        found = await client.call_tool("search_memory", {"query": "put the items away on the shelf"})
        assert found.structured_content is not None and found.structured_content["results"] == []


INITIALIZE = (
    '{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"protocolVersion":"2025-06-18",'
    '"capabilities":{},"clientInfo":{"name":"test","version":"1"}}}\n'
)
LIST_TOOLS = '{"jsonrpc":"2.0","method":"notifications/initialized"}\n{"jsonrpc":"2.0","id":2,"method":"tools/list"}\n'


def test_stdout_carries_only_the_protocol(tmp_path: Path) -> None:
    done = subprocess.run(
        [*server_command(), "--data-dir", str(tmp_path)], input=INITIALIZE, capture_output=True, text=True, timeout=60
    )
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    assert lines and all(line.startswith('{"jsonrpc":"2.0"') for line in lines), done.stdout


def test_stdio_from_a_pipe_and_from_files(tmp_path: Path) -> None:
    """stdin and stdout are read and written on the event loop when they are pipes, and through the
    SDK's own transport when they are regular files (the loop cannot watch those): both serve. (At
    the end of stdin the SDK cancels calls still running: their caller is gone.)"""
    with subprocess.Popen(
        [*server_command(), "--data-dir", str(tmp_path / "a")],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    ) as server:
        assert server.stdin is not None and server.stdout is not None
        server.stdin.write(INITIALIZE + LIST_TOOLS)
        server.stdin.flush()
        answers = [json.loads(server.stdout.readline()) for _ in range(2)]
        server.stdin.close()
        assert server.wait(timeout=60) == 0
    assert answers[0]["result"]["serverInfo"]["name"] == "robocog"
    assert any(t["name"] == "move_to" for t in answers[1]["result"]["tools"])

    (tmp_path / "in.jsonl").write_text(INITIALIZE, encoding="utf-8")
    with (tmp_path / "in.jsonl").open("rb") as source, (tmp_path / "out.jsonl").open("wb") as sink:
        cmd = [*server_command(), "--data-dir", str(tmp_path / "b")]
        done = subprocess.run(cmd, stdin=source, stdout=sink, stderr=subprocess.PIPE, timeout=60)
    assert done.returncode == 0, done.stderr
    answer = json.loads((tmp_path / "out.jsonl").read_text(encoding="utf-8"))
    assert answer["result"]["serverInfo"]["name"] == "robocog"


def test_a_bad_scene_fails_fast_with_the_reason(tmp_path: Path) -> None:
    bad = tmp_path / "scene.yaml"
    bad.write_text("name: x\nrobot_start: Nowhere\nlocations: []\n")
    done = subprocess.run([*server_command(), "--scene", str(bad)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert str(bad) in done.stderr and "locations" in done.stderr
