"""The client: the agent loop over MCP, the scripted models, replay, failure handling, the CLI.

Models are LiteLLM custom providers (the scripted planner and, for failure cases, canned turns
registered here through LiteLLM's own custom-provider mechanism); nothing needs a key or a network.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import litellm
import pytest
from litellm import CustomLLM, ModelResponse
from mcp import Client

from robocog.agent.client.connection import Robot, ServerSpec, connect
from robocog.agent.client.loop import function_definitions, run_episode
from robocog.agent.client.model import check_credentials
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.agent.policies.providers import model_response, register
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.errors import ModelServiceError
from robocog.shared.protocol import VISION_TOOLS
from robocog.shared.trace import ModelTurn, ToolResult, TraceEvent, read_trace
from tests.helpers import ROBOT_TOOLS, T1, T2, check_snapshot

pytestmark = pytest.mark.anyio


@pytest.fixture
async def stdio_robot(tmp_path: Path) -> AsyncIterator[Robot]:
    spec = ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(tmp_path / "memory")])
    async with connect(spec) as robot:
        yield robot


async def run(robot: Robot, task: str, model: str, trace: Trace | None = None, **settings: Any) -> Any:
    return await run_episode(
        robot.client,
        task,
        AgentSettings(model=model, **settings),
        trace or Trace(),
        system_prompt=robot.system_prompt,
        tools=robot.tools,
    )


async def verdict(robot: Robot, task_id: str) -> bool:
    result = await robot.client.call_tool("check_task", {"task_id": task_id})
    assert result.structured_content is not None
    return bool(result.structured_content["success"])


# --- through a real server process ---------------------------------------------------------------


async def test_scripted_planner_does_t1_then_t2_with_the_fewest_calls(stdio_robot: Robot) -> None:
    first = await run(stdio_robot, T1, "scripted/planner")
    assert (first.ended, first.believed_success, first.invocations) == (True, True, 1)
    assert await verdict(stdio_robot, "T1")
    # memory, look, plan, 11 actions for three items, 2 to learn that the TV cannot be grasped, look, end.
    assert first.tool_calls == 18
    second = await run(stdio_robot, T2, "scripted/planner")
    assert (second.ended, second.believed_success) == (True, True)
    assert await verdict(stdio_robot, "T2")
    # memory, look, plan, the robot walks back from the TV, 10 actions to swap through a parking spot, look, end.
    assert second.tool_calls == 16


async def test_memory_spares_the_planner_the_tv(stdio_robot: Robot) -> None:
    await run(stdio_robot, T1, "scripted/planner")
    await stdio_robot.client.call_tool("reset_world", {})
    again = await run(stdio_robot, T1, "scripted/planner")
    assert again.believed_success and await verdict(stdio_robot, "T1")
    assert again.tool_calls == 16  # it remembered that the TV cannot be grasped


async def test_the_refuser_is_stopped_after_ten_invocations(stdio_robot: Robot) -> None:
    result = await run(stdio_robot, T1, "scripted/refuser")
    assert (result.ended, result.stopped, result.invocations, result.tool_calls) == (False, True, 10, 0)
    assert result.believed_success is None
    assert not await verdict(stdio_robot, "T1")


async def test_the_overconfident_model_claims_a_success_it_did_not_achieve(stdio_robot: Robot) -> None:
    result = await run(stdio_robot, T1, "scripted/overconfident", params={"p": 1.0})
    assert result.ended and result.believed_success is True
    assert not await verdict(stdio_robot, "T1")


async def test_replay_reproduces_a_recorded_run(tmp_path: Path) -> None:
    recorded = tmp_path / "run.jsonl"

    def results(events: list[TraceEvent]) -> list[tuple[str, bool, Any]]:
        volatile = {"record_id", "episode_id", "when"}
        return [
            (e.name, e.is_error, {k: v for k, v in (e.structured or {}).items() if k not in volatile})
            for e in events
            if isinstance(e, ToolResult)
        ]

    async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(tmp_path / "a")])) as robot:
        await run(robot, T1, "scripted/planner", Trace(recorded))
        original = await verdict(robot, "T1")
    replayed_trace = Trace()
    async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(tmp_path / "b")])) as robot:
        replayed = await run(robot, T1, f"replay/{recorded}", replayed_trace)
        again = await verdict(robot, "T1")
    assert replayed.ended and original and again
    assert results(replayed_trace.events) == results(read_trace(recorded))


# --- failure handling (in-memory server: fast) ---------------------------------------------------


class CannedTurns(CustomLLM):
    """A model that answers with the given assistant messages in turn and records what it saw."""

    def __init__(self, turns: list[dict[str, Any]]) -> None:
        super().__init__()
        self.turns = turns
        self.seen: list[list[dict[str, Any]]] = []

    def completion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        self.seen.append([dict(m) for m in messages])
        turn = self.turns[min(len(self.seen) - 1, len(self.turns) - 1)]
        if isinstance(turn, Exception):
            raise turn
        return model_response(model, turn, 0)

    async def acompletion(self, model: str, messages: list, *args: Any, **kwargs: Any) -> ModelResponse:
        return self.completion(model, messages)


def tool_turn(name: str, arguments: str, call_id: str) -> dict[str, Any]:
    return {
        "role": "assistant",
        "content": None,
        "tool_calls": [{"id": call_id, "type": "function", "function": {"name": name, "arguments": arguments}}],
    }


@pytest.fixture
def canned() -> Iterator[Any]:
    providers: list[dict[str, Any]] = []

    def install(turns: list[Any]) -> CannedTurns:
        handler = CannedTurns(turns)
        register()
        litellm.custom_provider_map[:] = [p for p in litellm.custom_provider_map if p["provider"] != "canned"]
        litellm.custom_provider_map.append({"provider": "canned", "custom_handler": handler})
        providers.append({"provider": "canned"})
        from litellm.utils import custom_llm_setup

        custom_llm_setup()
        return handler

    yield install
    litellm.custom_provider_map[:] = [p for p in litellm.custom_provider_map if p["provider"] != "canned"]


@pytest.fixture
async def memory_robot(tmp_path: Path) -> AsyncIterator[Robot]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server) as client:
        tools = (await client.list_tools()).tools
        prompt = await client.get_prompt("robot_system")
        yield Robot(client, tools, prompt.messages[0].content.text, {}, "in-memory")  # type: ignore[union-attr]


async def test_malformed_arguments_and_unknown_tools_are_reported_to_the_model(
    memory_robot: Robot, canned: Any
) -> None:
    model = canned(
        [
            tool_turn("grab", '{"object": "cube"', "c1"),  # truncated JSON
            tool_turn("fly_to", '{"place": "moon"}', "c2"),  # no such tool
            tool_turn("move_to", '{"location": 42}', "c3"),  # fails the schema on the server
            tool_turn("end_task", json.dumps({"status": "failure", "description": T1, "summary": "gave up"}), "c4"),
        ]
    )
    trace = Trace()
    result = await run(memory_robot, T1, "canned/test", trace)
    assert result.ended and result.believed_success is False and result.tool_calls == 4
    errors = [e for e in trace.events if isinstance(e, ToolResult) and e.is_error]
    assert [e.name for e in errors] == ["grab", "fly_to", "move_to"]
    told = {m["tool_call_id"]: m["content"] for m in model.seen[-1] if m.get("role") == "tool"}
    assert "not a valid JSON object" in told["c1"]
    assert "no tool called 'fly_to'" in told["c2"] and "look_around" in told["c2"]
    assert "valid string" in told["c3"]


async def test_rate_limits_are_retried(memory_robot: Robot, canned: Any) -> None:
    limited = litellm.RateLimitError(message="slow down", llm_provider="canned", model="test")
    canned([limited, tool_turn("end_task", json.dumps({"status": "success", "description": T1, "summary": "."}), "c1")])
    result = await run(memory_robot, T1, "canned/test", backoff_s=0.01)
    assert result.ended and result.error is None


async def test_a_model_service_that_keeps_failing_ends_the_run_with_the_reason(
    memory_robot: Robot, canned: Any
) -> None:
    canned([litellm.ServiceUnavailableError(message="down", llm_provider="canned", model="test")])
    result = await run(memory_robot, T1, "canned/test", backoff_s=0.01, retries=2)
    assert (result.outcome, result.stopped) == ("error", False)  # an outage is not a refusal
    assert result.error == "ModelServiceError: canned/test answered 503 (unavailable): down (after 3 attempts)"


def test_a_missing_api_key_names_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(ModelServiceError, match="OPENAI_API_KEY"):
        check_credentials("gpt-4.1", None)
    check_credentials("scripted/planner", None)
    check_credentials("openai/local-model", "http://127.0.0.1:8080/v1")
    check_credentials("gpt-4.1", None, "sk-given")


async def test_control_tools_are_never_offered_to_the_model(memory_robot: Robot) -> None:
    names = {d["function"]["name"] for d in function_definitions(memory_robot.tools)}
    assert names == ROBOT_TOOLS - VISION_TOOLS, "a text-only model is not offered the camera"
    with_camera = {d["function"]["name"] for d in function_definitions(memory_robot.tools, vision=True)}
    assert with_camera == ROBOT_TOOLS


# --- the trace file ------------------------------------------------------------------------------


def test_trace_schema_matches_snapshot() -> None:
    from pydantic import TypeAdapter

    from robocog.shared.trace import TraceEvent as Event

    check_snapshot("trace_schema", TypeAdapter(Event).json_schema())


async def test_the_trace_records_turns_calls_results_and_the_end(stdio_robot: Robot, tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    await run(stdio_robot, T1, "scripted/planner", Trace(path))
    events = read_trace(path)
    kinds = [e.type for e in events]
    assert kinds[0] == "run_started"
    assert kinds.count("tool_call") == kinds.count("tool_result") == 18
    assert all(e.tokens_in > 0 for e in events if isinstance(e, ModelTurn))


# --- the command line ----------------------------------------------------------------------------


def robocog(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "robocog.agent.cli", *args], capture_output=True, text=True, timeout=180, cwd=cwd
    )


def test_robocog_run_prints_the_trace_and_exits_by_the_verdict(tmp_path: Path) -> None:
    done = robocog(
        "run", "T1", "T2", "--data-dir", str(tmp_path / "m"), "--trace", str(tmp_path / "t.jsonl"), cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert "[TOOL] grab(object='cube')" in done.stdout
    assert "Test results for task T1: success" in done.stdout
    assert "Test results for task T2: success" in done.stdout
    assert "\x1b[" not in done.stdout  # plain text when piped
    refused = robocog(
        "run", "T1", "--model", "scripted/refuser", "--quiet", "--data-dir", str(tmp_path / "m2"), cwd=tmp_path
    )
    assert refused.returncode == 1
    assert "T1: believed never ended, ground truth failure, 0 tool calls" in refused.stdout


# --- more of what the planner understands, in memory ---------------------------------------------


async def test_the_planner_brings_an_item_to_a_named_position(memory_robot: Robot) -> None:
    result = await run(memory_robot, "Bring the cube to the top of the Kitchen Shelf.", "scripted/planner")
    assert result.ended and result.believed_success is True
    state = await memory_robot.client.read_resource("robocog://world/state")
    cube = next(o for o in json.loads(state.contents[0].text)["objects"] if o["object"] == "cube")  # type: ignore[union-attr]
    assert (cube["location"], cube["position"]) == ("Kitchen Shelf", "top")


async def test_the_planner_reports_honestly_when_the_destination_is_full(memory_robot: Robot) -> None:
    trace = Trace()
    result = await run(memory_robot, "Put the box and the cube on the Kitchen Table.", "scripted/planner", trace)
    assert result.ended and result.believed_success is False
    assert result.tool_calls == 3  # memory, look, end: nothing moved
    assert result.summary is not None and "2 objects to place at Kitchen Table, which has 1 place position" in (
        result.summary
    )


async def test_the_planner_declines_what_it_cannot_do(memory_robot: Robot) -> None:
    result = await run(memory_robot, "Water the plants.", "scripted/planner")
    assert (result.ended, result.believed_success, result.tool_calls) == (True, False, 3)  # memory, look, end
    assert result.summary is not None and "do not know how" in result.summary


def test_robocog_chat_runs_tasks_typed_one_after_another(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robocog.agent.cli", "chat", "--quiet", "--data-dir", str(tmp_path / "m")],
        input="T1\nT2\n\n",
        capture_output=True,
        text=True,
        timeout=180,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert "T1: believed success, ground truth success" in done.stdout
    assert "T2: believed success, ground truth success" in done.stdout


def test_robocog_bench_times_a_server_and_checks_every_run(tmp_path: Path) -> None:
    done = robocog("bench", "--runs", "2", "--data-dir", str(tmp_path / "m"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    figures = json.loads(done.stdout)
    assert figures["bench.true_success_rate"] == 1.0 and figures["bench.tool_calls"] == 18
    assert figures["bench.episode_median_s"] > 0 and figures["bench.tool.move_to.p50_ms"] > 0
