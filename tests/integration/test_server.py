"""The MCP surface through an in-memory client: contract snapshots and every tool's paths."""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.contract.check import dump_contract
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.protocol import CONTROL_TOOLS, FURNITURE_TOOLS
from tests.helpers import (
    APP_TOOLS,
    CONTRACT_DIR,
    ROBOT_TOOLS,
    T1,
    T1_SEQUENCE,
    T2_SEQUENCE,
    action_args,
    check_snapshot,
)

pytestmark = pytest.mark.anyio


@pytest.fixture
async def robot(tmp_path: Path) -> AsyncIterator[Client]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server, raise_exceptions=True) as client:
        yield client


@pytest.fixture
async def plain_robot(tmp_path: Path) -> AsyncIterator[Client]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"))
    async with Client(server, raise_exceptions=True) as client:
        yield client


async def call(client: Client, tool: str, **arguments: Any) -> tuple[bool, dict[str, Any]]:
    """(is_error, structured content or parsed text) of one tool call."""
    result = await client.call_tool(tool, arguments)
    data = result.structured_content
    if data is None:
        text = result.content[0].text  # type: ignore[union-attr]
        data = {"text": text}
    return bool(result.is_error), data


# --- contract ------------------------------------------------------------------------------------


async def contract(client: Client) -> dict[str, Any]:
    """The canonical contract, as `robocog contract dump` prints it and the package ships it."""
    return await dump_contract(client)


async def test_default_profile_contract_matches_snapshot(plain_robot: Client) -> None:
    check_snapshot(CONTRACT_DIR / "default.json", await contract(plain_robot))


async def test_eval_profile_contract_matches_snapshot(robot: Client) -> None:
    check_snapshot(CONTRACT_DIR / "eval.json", await contract(robot))


async def test_default_profile_hides_the_eval_controls(plain_robot: Client) -> None:
    names = {t.name for t in (await plain_robot.list_tools()).tools}
    assert names == ROBOT_TOOLS | APP_TOOLS
    assert not names & CONTROL_TOOLS
    is_error, data = await call(plain_robot, "reset_world")
    assert is_error
    assert "reset_world" in data["text"]


async def test_the_eval_profile_publishes_exactly_the_controls_clients_leave_out(robot: Client) -> None:
    names = {t.name for t in (await robot.list_tools()).tools}
    assert names == ROBOT_TOOLS | CONTROL_TOOLS | APP_TOOLS


async def test_annotations_mark_read_only_tools_and_closed_world(plain_robot: Client) -> None:
    tools = {t.name: t for t in (await plain_robot.list_tools()).tools}
    read_only = {n for n, t in tools.items() if t.annotations and t.annotations.read_only_hint}
    assert read_only == {"look_around", "view_scratchpad", "search_memory", "look", "robot_view"}
    assert all(t.annotations and t.annotations.open_world_hint is False for t in tools.values())
    assert all(t.output_schema for t in tools.values())


# --- robot tools ---------------------------------------------------------------------------------


async def test_look_around_reports_location_hand_and_every_location(robot: Client) -> None:
    is_error, data = await call(robot, "look_around")
    assert not is_error
    assert data["location"] == "Front Door"
    assert data["holding"] is None
    assert len(data["locations"]) == 9
    shelf = next(loc for loc in data["locations"] if loc["name"] == "Kitchen Shelf")
    assert [p["name"] for p in shelf["place_positions"]] == ["top", "middle", "bottom"]
    assert shelf["neighbours"] == ["Kitchen Area Left"]


async def test_move_to_drives_and_reports_the_path(robot: Client) -> None:
    is_error, data = await call(robot, "move_to", location="Kitchen Shelf")
    assert not is_error
    assert data["path"] == ["Front Door", "Hallway Area Door", "Kitchen Door", "Kitchen Area Left", "Kitchen Shelf"]


async def test_move_to_unknown_location_is_a_tool_error_with_suggestions(robot: Client) -> None:
    is_error, data = await call(robot, "move_to", location="Kitchen Shelve")
    assert is_error
    assert data["error"] == "unknown_location"
    assert data["suggestions"][0] == "Kitchen Shelf"


async def test_grab_and_place_succeed(robot: Client) -> None:
    assert not (await call(robot, "grab", object="cube"))[0]
    await call(robot, "move_to", location="Kitchen Shelf")
    is_error, data = await call(robot, "place", location="Kitchen Shelf", position="top")
    assert not is_error
    assert data["object"] == "cube"
    state = json.loads((await robot.read_resource("robocog://world/state")).contents[0].text)  # type: ignore[union-attr]
    cube = next(o for o in state["objects"] if o["object"] == "cube")
    assert (cube["location"], cube["position"], cube["state"]) == ("Kitchen Shelf", "top", "on_position")


async def test_grab_failures_are_tool_errors(robot: Client) -> None:
    is_error, data = await call(robot, "grab", object="mug")
    assert is_error and data["error"] == "out_of_reach" and "Kitchen Table" in data["message"]
    is_error, data = await call(robot, "grab", object="cub")
    assert is_error and data["error"] == "unknown_object" and data["suggestions"] == ["cube"]
    await call(robot, "grab", object="cube")
    is_error, data = await call(robot, "grab", object="cube")
    assert is_error and data["error"] == "already_holding"


async def test_the_tv_cannot_be_grasped(robot: Client) -> None:
    await call(robot, "move_to", location="Living Room TV")
    is_error, data = await call(robot, "grab", object="tv")
    assert is_error and data["error"] == "not_graspable"


async def test_place_failures_are_tool_errors(robot: Client) -> None:
    is_error, data = await call(robot, "place", location="Front Door", position="floor")
    assert is_error and data["error"] == "nothing_held"
    await call(robot, "grab", object="cube")
    is_error, data = await call(robot, "place", location="Kitchen Shelf", position="top")
    assert is_error and data["error"] == "not_at_location"
    is_error, data = await call(robot, "place", location="Front Door", position="shelf")
    assert is_error and data["error"] == "unknown_position" and "floor" in data["message"]


async def test_place_on_an_occupied_position_names_the_free_ones(robot: Client) -> None:
    await call(robot, "move_to", location="Living Room")
    await call(robot, "grab", object="box")
    await call(robot, "move_to", location="Kitchen Table")
    is_error, data = await call(robot, "place", location="Kitchen Table", position="middle")
    assert is_error and data["error"] == "position_occupied" and "mug" in data["message"]


async def test_bad_arguments_get_a_readable_error_and_the_server_keeps_running(robot: Client) -> None:
    attacks: list[tuple[str, dict[str, Any]]] = [
        ("move_to", {}),
        ("move_to", {"location": 5}),
        ("move_to", {"location": ""}),
        ("grab", {"object": None}),
        ("place", {"location": "Front Door"}),
        ("end_task", {"status": "done", "description": "x", "summary": "y"}),
        ("search_memory", {"query": "x", "k": 0}),
        ("search_memory", {"query": "x", "k": 21}),
        ("reset_world", {"search_k": 0}),
        ("begin_task", {"task_id": "T9"}),
        ("begin_task", {}),
        ("no_such_tool", {}),
    ]
    for tool, arguments in attacks:
        result = await robot.call_tool(tool, arguments)
        assert result.is_error, (tool, arguments)
        assert result.content[0].text  # type: ignore[union-attr]
    assert not (await call(robot, "look_around"))[0]


async def test_scratchpad_round_trip(robot: Client) -> None:
    is_error, data = await call(robot, "add_to_scratchpad", text="Plan: cube first.")
    assert not is_error and data["entries"] == 1
    await call(robot, "add_to_scratchpad", text="Then the box.")
    _, data = await call(robot, "view_scratchpad")
    assert data["content"] == "Plan: cube first.\n\nThen the box."
    is_error, data = await call(robot, "add_to_scratchpad", text="x" * 5000)  # refused at the edge
    assert is_error and "at most 2000 are accepted" in data["text"]


async def test_end_task_stores_the_report_and_search_finds_it(robot: Client) -> None:
    _, data = await call(robot, "search_memory", query="put away the items")
    assert data["results"] == []
    is_error, data = await call(
        robot,
        "end_task",
        status="success",
        description="Put away all the items into the shelf.",
        summary="All shelved.",
    )
    assert not is_error and data["record_id"]
    await call(robot, "end_task", status="failure", description="Water the plants.", summary="No plants here.")
    _, data = await call(robot, "search_memory", query="put items away into the shelf")
    assert data["results"][0]["task_description"] == "Put away all the items into the shelf."
    assert data["results"][0]["status"] == "success"
    assert data["results"][0]["status_source"] == "believed"


async def test_a_new_episode_clears_the_scratchpad(robot: Client) -> None:
    await call(robot, "add_to_scratchpad", text="episode one")
    await call(robot, "end_task", status="failure", description="Something.", summary="Nothing.")
    _, data = await call(robot, "view_scratchpad")
    assert data["entries"] == 0


# --- eval controls -------------------------------------------------------------------------------


async def test_check_task_gives_a_reason_per_object(robot: Client) -> None:
    is_error, data = await call(robot, "check_task", task_id="T1")
    assert not is_error
    assert data["success"] is False
    assert {o["object"] for o in data["objects"]} == {"mug", "box", "cube"}
    is_error, data = await call(robot, "check_task", task_id="T9")
    assert is_error and "T1" in data["text"]


async def test_verified_labels_replace_a_false_belief(robot: Client) -> None:
    await call(robot, "reset_world", memory_labels="verified")
    await call(robot, "end_task", status="success", description="Put away all the items into the shelf.", summary="x")
    _, verdict = await call(robot, "check_task", task_id="T1")
    assert verdict["success"] is False
    _, data = await call(robot, "search_memory", query="Put away all the items into the shelf.")
    assert (data["results"][0]["status"], data["results"][0]["status_source"]) == ("failure", "verified")


async def test_a_t2_without_calls_keeps_t1_verified_as_a_success(robot: Client) -> None:
    """Issue 10: a T2 in which the model makes no call must not write T2's verdict into T1's record."""
    await call(robot, "reset_world", memory_labels="verified")
    _, begun = await call(robot, "begin_task", task_id="T1")
    assert (begun["task_id"], begun["prompt"]) == ("T1", T1)
    for action in T1_SEQUENCE:
        is_error, data = await call(robot, action[0], **action_args(action))
        assert not is_error, data
    await call(robot, "add_to_scratchpad", text="cube top, box middle, mug bottom")
    await call(robot, "end_task", status="success", description=T1, summary="All three on the shelf.")
    assert (await call(robot, "check_task", task_id="T1"))[1]["success"]
    _, begun = await call(robot, "begin_task", task_id="T2", keep_scratchpad=True)
    assert begun["scratchpad_entries"] == 1
    is_error, verdict = await call(robot, "check_task", task_id="T2")  # no call in T2
    assert not is_error and verdict["success"] is False
    _, found = await call(robot, "search_memory", query=T1)
    assert [(r["task_description"], r["status"], r["status_source"]) for r in found["results"]] == [
        (T1, "success", "verified")
    ]


async def test_search_memory_returns_the_harness_default_k(robot: Client) -> None:
    for i in range(6):
        await call(robot, "end_task", status="success", description=f"Task number {i}.", summary="x")
    assert len((await call(robot, "search_memory", query="task"))[1]["results"]) == 3
    await call(robot, "reset_world", search_k=5)
    assert len((await call(robot, "search_memory", query="task"))[1]["results"]) == 5
    assert len((await call(robot, "search_memory", query="task", k=1))[1]["results"]) == 1


async def test_reset_world_and_clear_memory(robot: Client) -> None:
    await call(robot, "grab", object="cube")
    await call(robot, "end_task", status="failure", description="Task.", summary="x")
    _, state = await call(robot, "reset_world")
    assert state["robot"]["holding"] is None
    assert next(o for o in state["objects"] if o["object"] == "cube")["position"] == "floor"
    _, data = await call(robot, "clear_memory")
    assert data["removed"] == 1


async def test_reset_world_clears_the_namespace_it_switches_to_when_asked(robot: Client) -> None:
    """Contract 3.3: `reset_world(clear_memory=true)` forgets the records of the namespace it is given
    (and no other), as a unit's start did with a reset and a `clear_memory`."""
    for namespace in ("unit-a", "unit-b"):
        await call(robot, "reset_world", memory_namespace=namespace)
        await call(robot, "end_task", status="success", description=f"Task of {namespace}.", summary="x")
    await call(robot, "reset_world", memory_namespace="unit-a")  # kept, without clear_memory
    assert len((await call(robot, "search_memory", query="Task"))[1]["results"]) == 1
    _, state = await call(robot, "reset_world", memory_namespace="unit-a", clear_memory=True)
    assert state["robot"]["location"] == "Front Door"
    assert (await call(robot, "search_memory", query="Task"))[1]["results"] == []
    await call(robot, "reset_world", memory_namespace="unit-b")
    assert [r["task_description"] for r in (await call(robot, "search_memory", query="Task"))[1]["results"]] == [
        "Task of unit-b."
    ]


async def test_check_task_judges_without_writing_the_verdict_when_told(robot: Client) -> None:
    """Contract 3.3: `check_task(record=false)` gives the same verdict and leaves the record as the
    model's end_task wrote it (a harness about to drop the namespace has no use for the verdict)."""
    await call(robot, "reset_world", memory_labels="verified")
    for record in (False, True):
        await call(robot, "reset_world", memory_namespace=f"record-{record}")
        await call(robot, "begin_task", task_id="T1")
        await call(robot, "end_task", status="success", description=T1, summary="Claimed, not done.")
        _, verdict = await call(robot, "check_task", task_id="T1", record=record)
        assert verdict["success"] is False
        _, found = await call(robot, "search_memory", query=T1)
        (hit,) = found["results"]
        assert (hit["status"], hit["status_source"]) == (("failure", "verified") if record else ("success", "believed"))


async def test_t1_then_t2_through_tool_calls(robot: Client) -> None:
    for action in T1_SEQUENCE:
        is_error, data = await call(robot, action[0], **action_args(action))
        assert not is_error, data
    await call(robot, "end_task", status="success", description="Put away all the items into the shelf.", summary=".")
    assert (await call(robot, "check_task", task_id="T1"))[1]["success"]
    for action in T2_SEQUENCE:
        is_error, data = await call(robot, action[0], **action_args(action))
        assert not is_error, data
    await call(robot, "end_task", status="success", description="Swap the mug and the cube in the shelf.", summary=".")
    assert (await call(robot, "check_task", task_id="T2"))[1]["success"]


# --- resources and prompts -----------------------------------------------------------------------


async def test_resources_serve_state_map_image_and_tasks(robot: Client) -> None:
    state = json.loads((await robot.read_resource("robocog://world/state")).contents[0].text)  # type: ignore[union-attr]
    assert state["robot"]["location"] == "Front Door"
    assert len(state["positions"]) == 8
    graph = json.loads((await robot.read_resource("robocog://world/map")).contents[0].text)  # type: ignore[union-attr]
    assert len(graph["edges"]) == 8
    image = (await robot.read_resource("robocog://world/image")).contents[0]
    import base64

    assert base64.b64decode(image.blob).startswith(b"\x89PNG")  # type: ignore[union-attr]
    tasks = json.loads((await robot.read_resource("robocog://tasks")).contents[0].text)  # type: ignore[union-attr]
    assert [t["id"] for t in tasks] == ["T1", "T2"]


async def test_the_description_resource_gives_the_world_in_words(robot: Client) -> None:
    contents = (await robot.read_resource("robocog://world/description")).contents[0]
    assert contents.mime_type == "text/plain"
    text = contents.text  # type: ignore[union-attr]
    assert text.startswith("These are the locations in the world:\n- Front Door\n")
    assert "    - floor: occupied by cube\n" in text and "    - top: empty\n" in text
    assert text.endswith("You are at: Front Door")
    await call(robot, "grab", object="cube")
    await call(robot, "move_to", location="Kitchen Shelf")
    text = (await robot.read_resource("robocog://world/description")).contents[0].text  # type: ignore[union-attr]
    assert "    - cube (in your hand)\n" in text and text.endswith("You are at: Kitchen Shelf")


async def test_the_paper_system_prompt_has_the_tools_and_no_honesty_lines(robot: Client) -> None:
    text = (await robot.get_prompt("robot_system_paper")).messages[0].content.text  # type: ignore[union-attr]
    for tool in ROBOT_TOOLS - FURNITURE_TOOLS:  # the paper's models had its eight tools
        assert tool in text, tool
    for extra in ("cannot be grasped", "claim success", "honest", "Kitchen", "Living Room", "hallway", "one object"):
        assert extra.lower() not in text.lower(), extra
    ours = (await robot.get_prompt("robot_system")).messages[0].content.text  # type: ignore[union-attr]
    assert "cannot be grasped" in ours and ours != text


async def test_prompts_give_the_system_prompt_and_each_task(robot: Client) -> None:
    system = await robot.get_prompt("robot_system")
    assert "end_task" in system.messages[0].content.text  # type: ignore[union-attr]
    t1 = await robot.get_prompt("T1")
    assert t1.messages[0].content.text == "Put away all the items into the shelf."  # type: ignore[union-attr]


async def test_progress_is_reported_while_driving(robot: Client) -> None:
    updates: list[tuple[float, float | None, str | None]] = []

    async def on_progress(progress: float, total: float | None, message: str | None) -> None:
        updates.append((progress, total, message))

    result = await robot.call_tool("move_to", {"location": "Kitchen Shelf"}, progress_callback=on_progress)
    assert not result.is_error
    assert [u[0] for u in updates] == [1, 2, 3, 4]
    assert updates[-1][1] == 4 and updates[-1][2] == "reached Kitchen Shelf"


async def test_a_cancelled_move_leaves_the_world_consistent(robot: Client) -> None:
    import anyio

    await call(robot, "grab", object="cube")
    with anyio.move_on_after(0.02):
        await robot.call_tool("move_to", {"location": "Living Room TV"})
    _, look = await call(robot, "look_around")
    assert look["location"] in {"Front Door", "Living Room TV"}  # at a location, never between two
    assert look["holding"] == "cube"
    _, state = await call(robot, "check_task", task_id="T1")
    assert {o["object"] for o in state["objects"]} == {"mug", "box", "cube"}
    is_error, moved = await call(robot, "move_to", location="Kitchen Shelf")
    assert not is_error and moved["location"] == "Kitchen Shelf"
