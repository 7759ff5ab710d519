"""robocog's lean MCP client over stdio (`robocog.agent.client.lean`): against a real `robocog-server`
it answers as the SDK's `Client` does; against a scripted server it gives every failure as the SDK
does (a JSON-RPC error, a closed connection, a timeout told to the server, a result out of its
schema), answers a server's ping and refuses its other requests, and ends a server that will not."""

from __future__ import annotations

import json
import sys
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any, cast

import pytest
from mcp import Client
from mcp.client.stdio import StdioServerParameters, stdio_client
from mcp.shared.exceptions import MCPError
from mcp_types import CONNECTION_CLOSED, METHOD_NOT_FOUND, REQUEST_TIMEOUT, Implementation, RequestParamsMeta

from robocog.agent.client.connection import ServerSpec, connect, default_server_command, unreachable
from robocog.agent.client.lean import LeanClient, StdioChannel, stdio_channel

pytestmark = pytest.mark.anyio

#: A server in a few lines, driven by what each tool's name asks for; it logs every line it reads.
SCRIPTED = r"""
import json, sys, time
log = open(sys.argv[1], "a")
TOOLS = [
    {"name": "fine", "inputSchema": {"type": "object"}},
    {"name": "shaped", "inputSchema": {"type": "object"},
     "outputSchema": {"type": "object", "properties": {"n": {"type": "integer"}}, "required": ["n"]}},
]
def send(message):
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()
def answer(request_id, result):
    send({"jsonrpc": "2.0", "id": request_id, "result": result})
for line in sys.stdin:
    log.write(line)
    log.flush()
    message = json.loads(line)
    method, request_id = message.get("method"), message.get("id")
    if request_id is None or method is None:
        continue  # a notification, or an answer to what we asked
    if method == "initialize" and "--mute" in sys.argv:
        continue  # never answers the handshake
    if method == "initialize":
        answer(request_id, {"protocolVersion": message["params"]["protocolVersion"], "capabilities": {"tools": {}},
                            "serverInfo": {"name": "scripted", "version": "1"},
                            "instructions": "scripted: MCP contract 9.9"})
    elif method == "tools/list":
        answer(request_id, {"tools": TOOLS})
    elif method == "tools/call":
        name = message["params"]["name"]
        if name == "fine":
            answer(request_id, {"content": [{"type": "text", "text": "done"}], "isError": False})
        elif name == "shaped":
            answer(request_id, {"content": [], "structuredContent": message["params"]["arguments"]})
        elif name == "refuse":
            send({"jsonrpc": "2.0", "id": request_id, "error": {"code": -32602, "message": "no such object: vase"}})
        elif name == "ask":
            send({"jsonrpc": "2.0", "id": "s1", "method": "ping"})
            send({"jsonrpc": "2.0", "id": "s2", "method": "sampling/createMessage", "params": {}})
            send({"jsonrpc": "2.0", "method": "notifications/message", "params": {"level": "info", "data": "hi"}})
            answer(request_id, {"content": [{"type": "text", "text": "asked"}]})
        elif name == "input":
            answer(request_id, {"resultType": "input_required", "inputRequests": {}})
        elif name == "slow":
            pass  # never answered
        elif name == "die":
            sys.exit(3)
if "--stubborn" in sys.argv:  # stdin closed: stays until killed
    while True:
        time.sleep(1)
"""


@asynccontextmanager
async def scripted(tmp_path: Path, *extra: str) -> AsyncIterator[tuple[LeanClient, Path]]:
    script, log = tmp_path / "server.py", tmp_path / "read.jsonl"
    script.write_text(SCRIPTED, encoding="utf-8")
    info = Implementation(name="robocog", version="test")
    with (tmp_path / "stderr.log").open("w") as errlog:
        async with (
            stdio_channel([sys.executable, str(script), str(log), *extra], {}, errlog, "scripted") as channel,
            LeanClient(channel, client_info=info, name="scripted") as client,
        ):
            await client.list_tools()
            yield client, log


def read(log: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines()]


async def test_the_handshake_then_each_request_as_the_sdk_writes_it(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, log):
        assert client.instructions == "scripted: MCP contract 9.9"
        meta = cast(RequestParamsMeta, {"robocog/model": "m"})
        result = await client.call_tool("fine", {"n": 1}, meta=meta)
        assert not result.is_error and result.content[0].text == "done"  # type: ignore[union-attr]
    initialize, initialized, listed, call = read(log)
    assert initialize["method"] == "initialize" and initialize["params"] == {
        "protocolVersion": "2025-11-25",
        "capabilities": {},
        "clientInfo": {"name": "robocog", "version": "test"},
    }
    assert initialized == {"jsonrpc": "2.0", "method": "notifications/initialized"}
    assert listed["method"] == "tools/list" and "params" not in listed
    assert call["params"] == {"name": "fine", "arguments": {"n": 1}, "_meta": {"robocog/model": "m"}}
    assert len({m["id"] for m in (initialize, listed, call)}) == 3


async def test_a_servers_error_is_the_requests_and_the_session_goes_on(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, _):
        with pytest.raises(MCPError, match="no such object: vase") as refused:
            await client.call_tool("refuse", {})
        assert refused.value.error.code == -32602
        assert not (await client.call_tool("fine", {})).is_error


async def test_a_result_out_of_its_schema_is_refused_as_the_sdk_refuses_it(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, _):
        assert (await client.call_tool("shaped", {"n": 3})).structured_content == {"n": 3}
        refused = r"Invalid structured content returned by tool shaped: 'n' is a required"
        with pytest.raises(RuntimeError, match=refused):
            await client.call_tool("shaped", {"m": 3})


async def test_a_result_that_asks_for_input_fails_its_request_naming_it(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, _):
        with pytest.raises(MCPError, match="'input_required' result, which a study cannot give"):
            await client.call_tool("input", {})


async def test_a_servers_ping_is_answered_and_its_other_requests_refused(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, log):
        assert (await client.call_tool("ask", {})).content[0].text == "asked"  # type: ignore[union-attr]
        await client.call_tool("fine", {})  # the answers below were written before this call
    answers = {m["id"]: m for m in read(log) if "method" not in m}
    assert answers["s1"] == {"jsonrpc": "2.0", "id": "s1", "result": {}}
    assert answers["s2"]["error"]["code"] == METHOD_NOT_FOUND


async def test_a_call_given_up_is_told_to_the_server_and_the_session_goes_on(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, log):
        with pytest.raises(MCPError) as timed_out:
            await client.call_tool("slow", {}, read_timeout_seconds=0.2)
        assert timed_out.value.error.code == REQUEST_TIMEOUT
        assert not (await client.call_tool("fine", {})).is_error
    slow = next(m for m in read(log) if m.get("params", {}).get("name") == "slow")
    cancelled = next(m for m in read(log) if m.get("method") == "notifications/cancelled")
    assert cancelled["params"]["requestId"] == slow["id"]
    assert cancelled["params"]["reason"] == "timed out after 0.2s"


async def test_a_handshake_given_up_is_not_cancelled(tmp_path: Path) -> None:
    """The protocol forbids cancelling the handshake: a client that gives up on it says nothing."""
    import anyio

    script, log = tmp_path / "server.py", tmp_path / "read.jsonl"
    script.write_text(SCRIPTED, encoding="utf-8")
    info = Implementation(name="robocog", version="test")
    with (tmp_path / "stderr.log").open("w") as errlog, anyio.move_on_after(0.5) as gave_up:
        async with (
            stdio_channel([sys.executable, str(script), str(log), "--mute"], {}, errlog, "mute") as channel,
            LeanClient(channel, client_info=info, name="mute"),
        ):
            pytest.fail("the handshake was never answered")
    assert gave_up.cancelled_caught
    assert [m["method"] for m in read(log)] == ["initialize"]


async def test_a_server_that_dies_fails_its_calls_as_a_closed_connection(tmp_path: Path) -> None:
    async with scripted(tmp_path) as (client, _):
        for _ in range(2):  # the call it died on, and any after
            with pytest.raises(MCPError) as closed:
                await client.call_tool("die", {})
            assert closed.value.error.code == CONNECTION_CLOSED and unreachable(closed.value)


async def test_a_server_that_stays_after_its_stdin_closes_is_ended(tmp_path: Path) -> None:
    started = time.monotonic()
    async with scripted(tmp_path, "--stubborn") as (client, _):
        await client.call_tool("fine", {})
    assert time.monotonic() - started < 3 * StdioChannel.EXIT_S + 2


async def test_a_command_that_cannot_start_says_so(tmp_path: Path) -> None:
    spec = ServerSpec(command=[str(tmp_path / "no-such-server")], lean=True)
    with pytest.raises(Exception, match="no-such-server"):
        async with connect(spec):
            pass


# --- against robocog's own server --------------------------------------------------------------------


CALLS: list[tuple[str, dict[str, Any]]] = [
    ("reset_world", {"seed": 3, "memory_namespace": "lean"}),
    ("begin_task", {"task_id": "T1", "episode_id": "compared"}),
    ("look_around", {}),
    ("move_to", {"location": "Living Room"}),
    ("grab", {"object": "vase"}),
    ("grab", {"object": "box"}),
    ("search_memory", {"query": "put the box away"}),
    ("move_to", {"location": "Nowhere"}),
    ("check_task", {"task_id": "T1"}),
]


def _comparable(result: Any) -> Any:
    data = result.model_dump(mode="json", by_alias=True, exclude_none=True)
    data.get("_meta", {}).pop("robocog/driver", None)
    return data


async def test_robocogs_server_answers_the_lean_client_as_it_answers_the_sdks(tmp_path: Path) -> None:
    lean_spec = ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(tmp_path / "lean")], lean=True)
    async with connect(lean_spec) as robot:
        assert isinstance(robot.client, LeanClient)
        lean = [_comparable(await robot.client.call_tool(name, args)) for name, args in CALLS]
        lean_catalogue = (robot.system_prompt, robot.tasks, robot.contract, [t.name for t in robot.tools])
        state = await robot.client.read_resource("robocog://world/state")
    command, *args = default_server_command()
    params = StdioServerParameters(
        command=command, args=[*args, "--profile", "eval", "--data-dir", str(tmp_path / "sdk")]
    )
    with (tmp_path / "sdk.log").open("w") as errlog:
        async with Client(stdio_client(params, errlog=errlog), mode="legacy") as client:  # the same protocol
            sdk = [_comparable(await client.call_tool(name, args)) for name, args in CALLS]
            sdk_state = await client.read_resource("robocog://world/state")
    async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(tmp_path / "sdk2")])) as robot:
        sdk_catalogue = (robot.system_prompt, robot.tasks, robot.contract, [t.name for t in robot.tools])
    assert lean == sdk
    assert lean_catalogue == sdk_catalogue and lean_catalogue[2] is not None
    assert json.loads(state.contents[0].text) == json.loads(sdk_state.contents[0].text)  # type: ignore[union-attr]
