"""Any MCP client drives the robot: the official SDK's default client (`mcp.Client(url)`, sessionless
MCP 2026-07-28) with no robocog code on its side, over real HTTP to a real server process.

The rules (server/robots/ownership.py, docs/security.md): on one robot, a client without a handle is the
anonymous driver and does T1 as it is; a handle (`robot_id`, minted by the call that takes the robot
or by reset_world) holds the robot from the first call that presents it, and then a call without
one may read but not act. On a fleet, each handle has its own robot; a call that acts without one is
told in one line how to get one, and takes no robot. The same through the router.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import anyio
import pytest
from mcp import Client
from mcp_types import CallToolResult, ElicitRequestParams, ElicitResult

from robocog.agent.client.loop import function_definitions
from tests.helpers import T1, T1_SEQUENCE, action_args, http_server, http_server_process
from tests.inspector_cli import inspector

pytestmark = pytest.mark.anyio


def text(result: CallToolResult) -> str:
    return " ".join(getattr(c, "text", "") for c in result.content)


async def ok(client: Client, tool: str, **arguments: Any) -> dict[str, Any]:
    result = await client.call_tool(tool, arguments)
    assert not result.is_error, text(result)
    assert isinstance(result.structured_content, dict)
    return result.structured_content


async def do_t1(client: Client, handle: str | None = None) -> None:
    """T1's twelve actions, each with the handle when there is one, then end_task."""
    extra = {"robot_id": handle} if handle else {}
    for action in T1_SEQUENCE:
        await ok(client, action[0], **action_args(action), **extra)


async def verdict(client: Client, handle: str | None = None) -> bool:
    extra = {"robot_id": handle} if handle else {}
    return bool((await ok(client, "check_task", task_id="T1", **extra))["success"])


@pytest.fixture(scope="module")
def robot_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("one")
    with http_server(tmp / "server.log", "--profile", "eval", "--data-dir", str(tmp / "m")) as url:
        yield url


@pytest.fixture(scope="module")
def fleet_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("fleet")
    with http_server(tmp / "server.log", "--profile", "eval", "--robots", "2", "--data-dir", str(tmp / "m")) as url:
        yield url


async def test_a_plain_client_without_a_handle_does_t1_on_one_robot(robot_url: str) -> None:
    async with Client(robot_url) as client:
        tools = {t.name: t for t in (await client.list_tools()).tools}
        schema = tools["move_to"].input_schema
        assert "robot_id" in schema["properties"] and "robot_id" not in schema.get("required", [])
        assert "robot_id" in (tools["move_to"].output_schema or {}).get("properties", {}), "the output declares it"
        offered = function_definitions(list(tools.values()), furniture=False)  # what robocog's client offers a model
        assert all("robot_id" not in d["function"]["parameters"]["properties"] for d in offered)
        reset = await ok(client, "reset_world")
        assert reset.get("robot_id"), "reset_world mints a handle (the plain client ignores it)"
        await ok(client, "begin_task", task_id="T1")
        await do_t1(client)
        await ok(client, "end_task", status="success", description=T1, summary="put the three items away")
        assert await verdict(client), "twelve actions, twelve done: T1 is true"


async def test_a_handle_holds_the_robot_and_an_id_less_intruder_may_only_read(robot_url: str) -> None:
    async with Client(robot_url) as holder, Client(robot_url) as intruder:
        minted = await ok(holder, "reset_world")
        handle = minted["robot_id"]
        assert f"robot_id='{handle}'" in minted["message"], "the text hands it over too"
        await ok(holder, "add_to_scratchpad", text="the holder's plan", robot_id=handle)  # presented: it holds now
        await ok(holder, "move_to", location="Kitchen Door", robot_id=handle)
        for tool, arguments in (("move_to", {"location": "Living Room"}), ("add_to_scratchpad", {"text": "mine"})):
            refused = await intruder.call_tool(tool, arguments)
            assert refused.is_error and "passes robot_id" in text(refused), text(refused)
            assert "\n" not in text(refused).removeprefix(f"Error executing tool {tool}: "), "one line"
        looked = await ok(intruder, "look_around")  # reading is open to everyone
        assert looked["location"] == "Kitchen Door"
        pad = await ok(holder, "view_scratchpad", robot_id=handle)
        assert "mine" not in json.dumps(pad) and "the holder's plan" in json.dumps(pad), "pads apart"
        empty = await intruder.call_tool("move_to", {"location": "Front Door", "robot_id": ""})
        assert empty.is_error and "passes robot_id" in text(empty), "an empty robot_id is no handle"
        forged = await intruder.call_tool("move_to", {"location": "Front Door", "robot_id": handle[:-1] + "x"})
        assert forged.is_error and "not a robot handle this server minted" in text(forged)
        assert (await ok(holder, "look_around", robot_id=handle))["location"] == "Kitchen Door", "never disturbed"


async def test_two_plain_clients_with_their_own_handles_do_t1_at_once_on_a_fleet(fleet_url: str) -> None:
    async def one(note: str) -> tuple[bool, str]:
        async with Client(fleet_url) as client:
            handle = (await ok(client, "reset_world"))["robot_id"]
            await ok(client, "begin_task", task_id="T1", robot_id=handle)
            await ok(client, "add_to_scratchpad", text=note, robot_id=handle)
            await do_t1(client, handle)
            pad = json.dumps(await ok(client, "view_scratchpad", robot_id=handle))
            await ok(client, "end_task", status="success", description=T1, summary=note, robot_id=handle)
            return await verdict(client, handle), pad

    results: dict[str, tuple[bool, str]] = {}

    async def run(note: str) -> None:
        results[note] = await one(note)

    async with anyio.create_task_group() as tg:
        tg.start_soon(run, "alpha's pad")
        tg.start_soon(run, "beta's pad")
    assert results["alpha's pad"][0] and results["beta's pad"][0], "both T1 true"
    assert "beta" not in results["alpha's pad"][1] and "alpha" not in results["beta's pad"][1], "pads apart"


async def test_an_id_less_call_that_acts_on_a_fleet_gets_one_line_and_takes_no_robot(tmp_path: Path) -> None:
    with http_server(tmp_path / "server.log", "--robots", "2", "--data-dir", str(tmp_path / "m")) as fleet_url:
        await _id_less_on_a_fleet(fleet_url)


async def _id_less_on_a_fleet(fleet_url: str) -> None:
    async with Client(fleet_url) as client:
        for _ in range(3):  # more than the fleet's robots: none is taken
            refused = await client.call_tool("move_to", {"location": "Kitchen Door"})
            line = text(refused).removeprefix("Error executing tool move_to: ")
            assert refused.is_error and "robot_id" in line and "look_around" in line and "\n" not in line, line
            assert "driven by other sessions" not in line
        # both robots are still free: two clients each get one
        async with Client(fleet_url) as a, Client(fleet_url) as b:
            first = (await ok(a, "look_around"))["robot_id"]
            second = (await ok(b, "look_around"))["robot_id"]
            assert first != second
            await ok(a, "move_to", location="Kitchen Door", robot_id=first)
            assert (await ok(b, "look_around", robot_id=second))["location"] == "Front Door"
            await ok(b, "move_to", location="Living Room Door", robot_id=second)
            # both robots are driven now: a third handle gets none, and is not handed one
            full = await client.call_tool("look_around", {})
            assert full.is_error and "all 2 robots" in text(full) and "robot_id=" not in text(full), text(full)


async def test_through_the_router_handles_spread_over_the_processes(tmp_path: Path) -> None:
    with http_server_process(
        tmp_path / "router.log", "--robots", "4", "--processes", "2", "--data-dir", str(tmp_path / "m"), timeout_s=120
    ) as (url, _):
        async with Client(url) as client:
            refused = await client.call_tool("grab", {"object": "cube"})
            assert refused.is_error and "robot_id" in text(refused)
            for i in range(8):  # forged handles naming process 0: refused, and never counted as its load
                forged = await client.call_tool("look_around", {"robot_id": f"0.forged{i}.deadbeef"})
                assert forged.is_error and "not a robot handle this server minted" in text(forged)
            handles = []
            for _ in range(4):
                handles.append((await ok(client, "look_around"))["robot_id"])
                await ok(client, "move_to", location="Kitchen Door", robot_id=handles[-1])  # presented
            origins = sorted(h.split(".", 1)[0] for h in handles)
            assert origins == ["0", "0", "1", "1"], f"two handles a process, not all on one: {origins}"
            for handle in handles:  # each handle's robot is its own, wherever it lives
                assert (await ok(client, "look_around", robot_id=handle))["location"] == "Kitchen Door"
            full = await client.call_tool("look_around", {})  # every robot is driven: true counts
            assert full.is_error and "all 4 of the server's are driven (--robots 4)" in text(full), text(full)


async def test_consent_works_for_a_plain_client(tmp_path: Path) -> None:
    asked: list[str] = []

    async def answer(context: Any, params: ElicitRequestParams) -> ElicitResult:
        asked.append(params.message)
        return ElicitResult(action="accept", content={"decision": "allow once"})

    with http_server(tmp_path / "server.log", "--confirm-actions", "--data-dir", str(tmp_path / "m")) as url:
        async with Client(url, elicitation_callback=answer) as client:
            moved = await ok(client, "move_to", location="Hallway Area Door")
            assert moved["location"] == "Hallway Area Door" and len(asked) == 1
            assert "move_to(location='Hallway Area Door')" in asked[0]
            handle = moved["robot_id"]  # the call that took the robot minted a handle: present it
            await ok(client, "move_to", location="Kitchen Door", robot_id=handle)
            assert len(asked) == 2
        others: list[str] = []

        async def other(context: Any, params: ElicitRequestParams) -> ElicitResult:
            others.append(params.message)
            return ElicitResult(action="accept", content={"decision": "allow once"})

        async with Client(url, elicitation_callback=other) as intruder:  # the handle holds: refused unasked
            refused = await intruder.call_tool("move_to", {"location": "Living Room Door"})
            assert refused.is_error and "passes robot_id" in text(refused) and others == [], others
        async with Client(url) as mute:  # no elicitation: told what to do, the robot does not move
            refused = await mute.call_tool("move_to", {"location": "Kitchen Door", "robot_id": handle})
            assert refused.is_error and "elicitation" in text(refused)


def call(location: str) -> list[str]:
    return ["--tool-name", "move_to", "--tool-arg", f"location={location}"]


def test_back_to_back_inspector_cli_calls_both_act(tmp_path: Path) -> None:
    with http_server(tmp_path / "server.log", "--data-dir", str(tmp_path / "m")) as url:
        for location in ("Kitchen Door", "Hallway Area Door", "Living Room Door"):
            answer = inspector(url, "tools/call", *call(location))
            assert not answer.get("isError"), answer
            assert answer["structuredContent"]["location"] == location


def test_a_busy_viewer_port_leaves_the_mcp_server_running(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with http_server_process(tmp_path / "server.log", "--view", str(port), "--data-dir", str(tmp_path / "m")) as (
            url,
            proc,
        ):

            async def drive() -> str:
                async with Client(url) as client:
                    return str((await ok(client, "move_to", location="Kitchen Door"))["location"])

            assert anyio.run(drive) == "Kitchen Door"
            assert proc.poll() is None
            log = (tmp_path / "server.log").read_text()
            said = [line for line in log.splitlines() if f"port {port}" in line and "viewer" in line]
            assert len(said) == 1 and "in use" in said[0], log[-2000:]


async def test_a_viewer_that_fails_leaves_the_mcp_server_running(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from robocog.server.app import optional

    async def broken() -> None:
        raise OSError("the socket went away")

    await optional("the live viewer", broken)  # no exception escapes: the server's task group lives on
    said = capsys.readouterr().err.strip().splitlines()
    assert said == [
        "robocog-server: the live viewer stopped (OSError: the socket went away); the MCP server carries on"
    ]


def test_the_live_viewer_never_shows_a_handle(tmp_path: Path) -> None:
    import re
    import urllib.request

    log = tmp_path / "server.log"
    with http_server_process(log, "--profile", "eval", "--view", "0", "--data-dir", str(tmp_path / "m")) as (url, _):

        async def drive() -> str:
            async with Client(url) as client:
                handle = str((await ok(client, "reset_world"))["robot_id"])
                await ok(client, "move_to", location="Kitchen Door", robot_id=handle)
                return handle

        handle = anyio.run(drive)
        viewer = re.search(r"live viewer at (http://\S+/)", log.read_text())
        assert viewer, log.read_text()[-2000:]
        with urllib.request.urlopen(viewer.group(1) + "api/state", timeout=10) as page:
            shown = page.read().decode()
        assert "reset_world" in shown and "move_to" in shown, "the calls are shown"
        assert handle not in shown and handle.rsplit(".", 1)[-1] not in shown, "their handle is not"
