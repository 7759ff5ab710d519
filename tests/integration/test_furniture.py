"""Furniture that opens, through MCP (an in-memory client on kitchen_plus): open and close with their
structured results, what a closed container hides, failures as results, reset_world's observe, and
the paper's protocol offering its eight tools only."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.client.loop import function_definitions
from robocog.agent.study_protocols import PROTOCOLS
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.controls import EvalControls, mcp_call
from robocog.shared.protocol import FURNITURE_TOOLS, PAPER_TOOLS

pytestmark = pytest.mark.anyio


@pytest.fixture
async def robot(tmp_path: Path) -> AsyncIterator[Client]:
    config = SessionConfig(scene=Path("kitchen_plus"), data_dir=tmp_path / "memory")
    server = build_server(config, profile="eval")
    async with Client(server, raise_exceptions=True) as client:
        yield client


async def call(client: Client, tool: str, **arguments: Any) -> tuple[bool, dict[str, Any]]:
    result = await client.call_tool(tool, arguments)
    assert result.structured_content is not None, result.content
    return bool(result.is_error), result.structured_content


async def test_open_and_close_a_drawer_through_mcp(robot: Client) -> None:
    _, look = await call(robot, "look_around")
    assert {f["name"]: f["state"] for f in look["furniture"]} == {
        "kitchen_drawer": "closed",
        "kitchen_cabinet": "closed",
        "fridge": "closed",
    }
    assert not any("sponge" in v["objects"] for v in look["locations"])
    is_error, grab = await call(robot, "grab", object="sponge")
    assert is_error and grab["error"] == "out_of_reach" and "closed" in grab["message"]
    assert grab["container"] == "kitchen_drawer"  # the furniture to open, named apart from the message
    is_error, away = await call(robot, "open", furniture="kitchen_drawer")
    assert is_error and away["error"] == "not_at_location"
    await call(robot, "move_to", location="Kitchen Drawer")
    is_error, opened = await call(robot, "open", furniture="kitchen_drawer")
    assert not is_error
    assert (opened["outcome"], opened["state"], opened["opening"]) == ("opened", "open", 1.0)
    assert opened["steps"] > 0 and "sponge" in opened["message"]
    _, look = await call(robot, "look_around")
    here = next(v for v in look["locations"] if v["name"] == "Kitchen Drawer")
    assert here["objects"] == ["sponge"]
    is_error, closed = await call(robot, "close", furniture="kitchen_drawer")
    assert not is_error and closed["outcome"] == "closed"
    _, state = await call(robot, "reset_world")  # the start's ground truth: each container's contents
    assert [f["contents"] for f in state["furniture"]] == [["sponge"], [], ["bottle"]]
    assert next(o for o in state["objects"] if o["object"] == "sponge")["inside"] == "kitchen_drawer"
    is_error, unknown = await call(robot, "open", furniture="freezer")
    assert is_error and unknown["error"] == "unknown_furniture" and "fridge" in unknown["message"]


async def test_reset_world_sets_what_look_around_reveals(robot: Client) -> None:
    _, house = await call(robot, "look_around")
    assert "observed" not in house and len(house["locations"]) == 12
    await EvalControls(mcp_call(robot)).reset_world(seed=0, observe="location")  # the harness's way
    _, here = await call(robot, "look_around")
    assert here["observed"] == "location" and [v["name"] for v in here["locations"]] == ["Front Door"]
    await call(robot, "reset_world")  # observe holds until set again
    _, still = await call(robot, "look_around")
    assert still["observed"] == "location"
    await call(robot, "reset_world", observe="room")
    _, room = await call(robot, "look_around")
    assert room["observed"] == "room" and len(room["locations"]) == 4
    await call(robot, "reset_world", observe="house")
    _, house = await call(robot, "look_around")
    assert "observed" not in house


async def test_the_papers_protocol_offers_its_eight_tools_and_ours_open_and_close(robot: Client) -> None:
    tools = (await robot.list_tools()).tools
    assert {t.name for t in tools} >= FURNITURE_TOOLS
    paper = PROTOCOLS["paper"]
    offered = {d["function"]["name"] for d in function_definitions(tools, furniture=paper.offers_furniture)}
    assert offered == set(PAPER_TOOLS)
    ours = PROTOCOLS["robocog"]
    offered = {d["function"]["name"] for d in function_definitions(tools, furniture=ours.offers_furniture)}
    assert offered == set(PAPER_TOOLS) | FURNITURE_TOOLS


async def test_a_client_offers_open_and_close_only_in_a_world_with_furniture_that_opens(
    robot: Client, tmp_path: Path
) -> None:
    from robocog.agent.client.loop import world_has_furniture

    assert await world_has_furniture(robot, (await robot.list_tools()).tools)
    household = build_server(SessionConfig(data_dir=tmp_path / "household"), profile="eval")
    async with Client(household, raise_exceptions=True) as paper_world:
        assert not await world_has_furniture(paper_world, (await paper_world.list_tools()).tools)


@pytest.mark.filterwarnings("ignore::mcp.shared.exceptions.MCPDeprecationWarning")  # a 2025-11-25 client's subscribe
async def test_a_subscriber_hears_of_a_door_opened_not_of_a_failed_open(tmp_path: Path) -> None:
    import anyio

    updated: list[str] = []

    async def on_message(message: Any) -> None:
        if getattr(message, "method", None) == "notifications/resources/updated":
            updated.append(str(message.params.uri))

    config = SessionConfig(scene=Path("kitchen_plus"), data_dir=tmp_path / "memory")
    client = Client(build_server(config), raise_exceptions=True, mode="legacy")
    client.message_handler = on_message
    async with client:
        await client.subscribe_resource("robocog://world/state")
        await client.call_tool("open", {"furniture": "fridge"})  # not at the fridge: nothing moved
        await client.call_tool("move_to", {"location": "Fridge"})
        await client.call_tool("open", {"furniture": "fridge"})
        with anyio.fail_after(5):
            while len(updated) < 2:
                await anyio.sleep(0.01)
        await anyio.sleep(0.05)
    assert updated == ["robocog://world/state"] * 2  # the move, then the fridge's door


async def test_an_episode_told_whether_there_is_furniture_does_not_ask_the_world_again(
    robot: Client, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The harness asks once per attempt, for the provenance, and tells the episode."""
    from robocog.agent.client import loop
    from robocog.agent.client.settings import AgentSettings
    from robocog.agent.client.trace_sinks import Trace

    asked: list[bool] = []
    real = loop.world_has_furniture

    async def counted(client: Client, tools: Any) -> bool:
        asked.append(await real(client, tools))
        return asked[-1]

    monkeypatch.setattr(loop, "world_has_furniture", counted)
    tools = (await robot.list_tools()).tools
    offered: dict[bool | None, set[str]] = {}
    for told in (None, False, True):
        trace = Trace(tmp_path / f"run-{told}.jsonl")
        settings = AgentSettings(model="scripted/planner", max_invocations=1, max_steps=1)
        await loop.run_episode(robot, "Look around.", settings, trace, system_prompt="", tools=tools, furniture=told)
        trace.close()
        started = next(e for e in trace.events if e.type == "run_started")
        offered[told] = set(started.tools) & FURNITURE_TOOLS
    assert asked == [True]  # only the episode that was not told asked
    assert offered == {None: FURNITURE_TOOLS, False: set(), True: FURNITURE_TOOLS}


async def test_the_harness_learns_from_a_reset_whether_its_world_has_furniture(tmp_path: Path) -> None:
    """What reset_world answers is the world it made: the harness's controls remember whether it has
    furniture that opens, as reading its state would tell, and the attempts after it read nothing."""
    from robocog.agent.client.connection import Robot
    from robocog.agent.client.loop import world_has_furniture
    from robocog.agent.harness.runner import Runner

    for scene, expected in ((Path("kitchen_plus"), True), (None, False)):
        config = SessionConfig(scene=scene, data_dir=tmp_path / f"memory-{expected}")
        async with Client(build_server(config, profile="eval"), raise_exceptions=True) as client:
            tools = (await client.list_tools()).tools
            robot = Robot(client=client, tools=tools, system_prompt="", tasks={}, label="in-memory")
            assert robot.furniture is None
            await Runner.controls(robot).reset_world(seed=0)
            assert robot.furniture is expected
            assert await world_has_furniture(client, tools) is expected  # the state read agrees

            reads: list[str] = []
            real = client.read_resource

            async def counted(uri: Any, real: Any = real, reads: list[str] = reads) -> Any:
                reads.append(str(uri))
                return await real(uri)

            client.read_resource = counted
            assert await world_has_furniture(client, tools, known=robot.furniture) is expected
            assert reads == []
