"""Perturbations through MCP (an in-memory client on the eval profile): reset_world(perturbations=...)
and the typed controls, announced and silent perturbations in the tool results and their `_meta`,
ground truth after a slip, a perturbation the scene cannot have refused as a tool error, and the
client's trace (a `perturbation` event after the result of the call during which it happened)."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.client.loop import run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.controls import EvalControls, mcp_call
from robocog.shared.perturbations import PERTURBATION_META_KEY, Perturbation
from robocog.shared.trace import Perturbed, ToolResult, read_trace
from tests.fake_llm import FakeLLM, Turn

pytestmark = pytest.mark.anyio

BLOCK = {"kind": "block_edge", "edge": ["Hallway Area Door", "Kitchen Door"], "duration": 2}


@pytest.fixture
async def robot(tmp_path: Path) -> AsyncIterator[Client]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server, raise_exceptions=True) as client:
        yield client


@pytest.fixture
def fake() -> Iterator[FakeLLM]:
    with FakeLLM() as server:
        yield server
        assert not server.problems, server.problems


async def call(client: Client, tool: str, **arguments: Any) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The structured result and the perturbations its `_meta` carries."""
    result = await client.call_tool(tool, arguments)
    assert result.structured_content is not None, result.content
    return result.structured_content, (result.meta or {}).get(PERTURBATION_META_KEY, [])


async def test_a_silent_block_fails_move_to_and_rides_in_meta_only(robot: Client) -> None:
    await call(robot, "reset_world", perturbations=[BLOCK])
    moved, happened = await call(robot, "move_to", location="Kitchen Table")
    assert (moved["status"], moved["error"], moved["location"]) == ("failure", "no_path", "Hallway Area Door")
    assert "Something changed" not in moved["message"]
    assert [(e["kind"], e["call"], e["announced"], e["edge"]) for e in happened] == [
        ("block_edge", 1, False, ["Hallway Area Door", "Kitchen Door"])
    ]
    _, happened = await call(robot, "look_around")  # call 2: still blocked, nothing new
    assert happened == []
    moved, happened = await call(robot, "move_to", location="Kitchen Table")  # call 3: clear again
    assert moved["status"] == "success" and [e["ended"] for e in happened] == [True]


async def test_an_announced_slip_says_so_and_ground_truth_has_the_object_on_the_floor(robot: Client) -> None:
    controls = EvalControls(mcp_call(robot))
    await controls.reset_world(seed=2, perturbations=[Perturbation(kind="slip", announce=True)])
    await call(robot, "grab", object="cube")
    moved, happened = await call(robot, "move_to", location="Kitchen Shelf")
    assert moved["status"] == "success" and "Something changed: The cube slipped out of the hand" in moved["message"]
    [event] = happened
    state = (await robot.read_resource("robocog://world/state")).contents[0]
    text = getattr(state, "text", "")
    assert '"holding":null' in text.replace(" ", "")
    assert event["kind"] == "slip" and event["object"] == "cube" and event["announced"]


async def test_a_perturbation_the_scene_cannot_have_is_a_tool_error(robot: Client) -> None:
    result = await robot.call_tool("reset_world", {"perturbations": [{"kind": "close_container", "container": "x"}]})
    assert result.is_error and "'x' is not a container" in " ".join(getattr(c, "text", "") for c in result.content)


async def test_the_clients_trace_records_each_perturbation_after_its_result(
    robot: Client, fake: FakeLLM, tmp_path: Path
) -> None:
    await call(robot, "reset_world", perturbations=[{**BLOCK, "announce": True}])
    fake.script = [
        Turn(tool_calls=[("move_to", {"location": "Kitchen Table"})]),
        Turn(tool_calls=[("end_task", {"status": "failure", "description": "go", "summary": "blocked"})]),
    ]
    tools = (await robot.list_tools()).tools
    settings = AgentSettings(model="openai/fake", api_base=fake.api_base("openai/fake"), retries=0)
    trace = Trace(tmp_path / "run.jsonl")
    await run_episode(robot, "Go to the table.", settings, trace, system_prompt="You drive a robot.", tools=tools)
    trace.close()
    events = read_trace(tmp_path / "run.jsonl")
    kinds = [e.type for e in events if isinstance(e, ToolResult | Perturbed)]
    assert kinds == ["tool_result", "perturbation", "tool_result"]
    result = next(e for e in events if isinstance(e, ToolResult))
    perturbed = next(e for e in events if isinstance(e, Perturbed))
    assert perturbed.id == result.id and perturbed.event.kind == "block_edge" and perturbed.event.announced
    assert "Something changed: The way between Hallway Area Door and Kitchen Door is blocked." in result.content


async def test_a_study_sends_its_perturbations_with_every_reset_and_traces_them(tmp_path: Path) -> None:
    """The planner's T1 under a slip (a server process through `robocog eval`'s runner): the trace has
    the slip after its call's result; the paper's protocol refuses perturbations."""
    from robocog.agent.harness.study import run_eval
    from robocog.shared.evaluation import EvalConfig, ModelSpec

    slip = Perturbation(kind="slip", announce=True)
    with pytest.raises(ValueError, match="the paper's protocol runs the paper's world as it is"):
        EvalConfig(name="p", protocol="paper", models=[ModelSpec(model="scripted/planner")], perturbations=[slip])
    config = EvalConfig(
        name="perturbed",
        models=[ModelSpec(model="scripted/planner")],
        tasks=["T1"],
        trials=1,
        memory_iterations=1,
        perturbations=[slip],
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    assert len(rows) == 1
    [trace] = list((tmp_path / "r.traces").rglob("*.jsonl"))
    events = read_trace(trace)
    [slipped] = [e for e in events if isinstance(e, Perturbed)]
    assert slipped.event.kind == "slip" and slipped.event.announced
    result = next(e for e in events if isinstance(e, ToolResult) and e.id == slipped.id)
    assert result.name == "move_to" and "Something changed: The " in result.content
    # the row says what went wrong, and the report sets perturbed attempts apart
    from robocog.agent.analysis.report import render

    assert rows[0].perturbations == ["slip"]
    calm = rows[0].model_copy(update={"perturbations": [], "trial": 1, "true_success": True})
    report = render([rows[0], calm], tmp_path / "report").read_text(encoding="utf-8")
    section = report.split("## Perturbations", 1)[1]
    line = next(x for x in section.splitlines() if x.startswith("| scripted/planner"))
    success = "100.0% (1/1)" if rows[0].true_success else "0.0% (0/1)"
    assert line.split(" | ")[1:5] == ["1 of 2", "slip ×1", success, "100.0% (1/1)"]
    assert "## Perturbations" not in render([calm], tmp_path / "calm").read_text(encoding="utf-8")
