"""Local model servers as they really are, over real HTTP (LiteLLM → `tests.fake_llm`) and a real
robot server: a llama.cpp server's edges (tools dropped without `tool_choice`, a 500 on
`content: null`, `tests.fake_llm.llama_cpp`) and a small model's slips (double-encoded arguments, tool
calls written as text, a turn cut at the token limit), each counted, never hidden; a deterministic
server error is not retried as if it were transient; an errored run reads as an error.
The shared setup is in tests/e2e/model_routes.py and model_route_fixtures.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.agent.analysis.taxonomy import classify, slips
from robocog.agent.client.connection import Robot
from robocog.agent.client.local_servers import LOCAL_MAX_LENGTH
from robocog.agent.client.model import sendable_request
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.provenance import function_definition
from robocog.shared.trace import ModelTurn, ToolCall, ToolResult
from tests.e2e.model_route_fixtures import anyio_backend_fixture, fake_fixture, fresh_fixture, robot_fixture  # noqa: F401
from tests.e2e.model_routes import END, KEY_VARIABLES, ROUTES, episode
from tests.fake_llm import TEMPLATE_ERROR, Fail, FakeLLM, Request, Turn, llama_cpp, planner_script

pytestmark = pytest.mark.anyio

LOCAL = "openai/qwen15"


def _settings(fake: FakeLLM, model: str = LOCAL, **more: object) -> AgentSettings:
    return AgentSettings(model=model, api_base=fake.api_base(model), **more)  # type: ignore[arg-type]


# --- requests that local servers accept ----------------------------------------------------------


async def test_t1_through_a_llama_cpp_server_reaches_the_robot(robot: Robot, fake: FakeLLM) -> None:
    # The server drops tools sent without tool_choice, fails on content: null and on a grammar for a
    # maxLength of 2,000: the planner behind it does T1 only if every request names tool_choice, no
    # assistant message carries null and no text argument is sent a bound that long.
    fake.script = llama_cpp(planner_script())
    result, truth = await episode(robot, _settings(fake, retries=0))
    assert (result.outcome, result.believed_success, truth) == ("ended", True, True), result.error
    assert result.tool_calls > 10 and result.text_tool_calls == 0
    bodies = [r.body for r in fake.model_requests]
    assert all(b["tool_choice"] == "auto" and b["tools"] for b in bodies)
    sent = [m for b in bodies for m in b["messages"] if m["role"] == "assistant"]
    assert sent and all(m.get("content") == "" for m in sent if m.get("tool_calls"))
    assert max(_max_lengths(bodies[0]["tools"])) == 200 <= LOCAL_MAX_LENGTH  # the names keep their bound


def test_only_a_local_server_is_sent_the_tools_without_their_long_bounds() -> None:
    tools = [function_definition("end_task", "End.", END_TASK_SCHEMA)]
    _, local, _ = sendable_request(LOCAL, [], tools, "http://127.0.0.1:8080/v1")
    _, cloud, _ = sendable_request("gpt-4.1", [], tools, None)
    assert _max_lengths(local) == [200] and _max_lengths(cloud) == [200, 4000]  # the robot server enforces both


END_TASK_SCHEMA = {
    "type": "object",
    "properties": {"status": {"type": "string", "maxLength": 200}, "summary": {"type": "string", "maxLength": 4000}},
}


def _max_lengths(value: object) -> list[int]:
    if isinstance(value, dict):
        own = [value["maxLength"]] if isinstance(value.get("maxLength"), int) else []
        return own + [n for v in value.values() for n in _max_lengths(v)]
    if isinstance(value, list):
        return [n for v in value for n in _max_lengths(v)]
    return []


@pytest.mark.parametrize("model", ROUTES)
async def test_every_route_takes_the_adapted_request(robot: Robot, fake: FakeLLM, model: str) -> None:
    fake.reply(Turn(tool_calls=[("look_around", {})]), Turn(tool_calls=[END]))
    result, _ = await episode(robot, _settings(fake, model))
    assert (result.outcome, result.tool_calls) == ("ended", 2), result.error
    first, second = fake.model_requests
    if model.startswith("openai/"):  # OpenAI's own default, said out loud for llama.cpp
        assert first.body["tool_choice"] == "auto"
    # The tool-call turn goes back without a null content on every route (Anthropic: no empty block).
    assert next(m for m in second.neutral() if m["role"] == "assistant")["tool_calls"]
    assert not [m for m in second.messages if m["role"] == "assistant" and m.get("content", "") is None]


# --- a deterministic error is not retried --------------------------------------------------------


async def test_the_same_500_twice_ends_the_attempt_with_the_servers_message(robot: Robot, fake: FakeLLM) -> None:
    fake.script = lambda request: Fail(500, TEMPLATE_ERROR)
    result, _ = await episode(robot, _settings(fake, retries=4, backoff_s=0.01))
    assert result.outcome == "error" and len(fake.model_requests) == 2
    assert result.error == (
        f"ModelServiceError: {LOCAL} answered 500 (server error): {TEMPLATE_ERROR} (the same answer twice: not retried)"
    )


async def test_a_503_with_the_same_body_is_still_retried(fake: FakeLLM, robot: Robot) -> None:
    fake.reply(Fail(503, "loading model"), Fail(503, "loading model"), Turn(tool_calls=[END]))
    result, _ = await episode(robot, _settings(fake, retries=4, backoff_s=0.01))
    assert result.outcome == "ended" and len(fake.model_requests) == 3  # "later" by its meaning


# --- slips counted, and run where the intent is clear --------------------------------------------


async def test_double_encoded_arguments_run_as_meant_and_count_a_parse_slip(robot: Robot, fake: FakeLLM) -> None:
    meant = {"location": "Kitchen Table"}
    fake.reply(Turn(tool_calls=[("move_to", json.dumps(json.dumps(meant)))]), Turn(tool_calls=[END]))
    trace = Trace()
    result, _ = await episode(robot, _settings(fake), trace)
    assert result.outcome == "ended"
    call = next(e for e in trace.events if isinstance(e, ToolCall) and e.name == "move_to")
    answer = next(e for e in trace.events if isinstance(e, ToolResult) and e.name == "move_to")
    assert (call.arguments, call.slip) == (meant, "double_encoded")
    assert not answer.is_error and "Kitchen Table" in answer.content  # run, and nothing misleading said
    # The model's view of its own call is the object it meant, not the string it wrote.
    history = fake.model_requests[1].body["messages"]
    sent = next(m for m in history if m["role"] == "assistant")["tool_calls"][0]["function"]["arguments"]
    assert json.loads(sent) == meant
    assert classify(trace.events)["parse"] == 1 and slips(trace.events) == {"double_encoded": 1}


@pytest.mark.parametrize(
    "text",
    [
        '<tool_call>\n{"name": "look_around", "arguments": {}}\n</tool_call>',
        '<function name="look_around" arguments="{}"/>',
        "functions.look_around:\n{}",
        'I will look first. {"name": "look_around", "arguments": {}}',
    ],
    ids=["hermes", "function-tag", "functions-dot", "json"],
)
async def test_a_tool_call_written_as_text_is_counted_as_a_parse_error_not_run(
    robot: Robot, fake: FakeLLM, text: str
) -> None:
    fake.reply(Turn(text=text), Turn(tool_calls=[END]))
    trace = Trace()
    result, _ = await episode(robot, _settings(fake), trace)
    assert (result.outcome, result.tool_calls, result.text_tool_calls) == ("ended", 1, 1)
    assert not any(isinstance(e, ToolCall) and e.name == "look_around" for e in trace.events)  # not run
    turn = next(e for e in trace.events if isinstance(e, ModelTurn))
    assert turn.text_tool_calls == 1
    assert classify(trace.events)["parse"] == 1 and slips(trace.events) == {"text_tool_calls": 1}


async def test_prose_is_not_a_text_tool_call(robot: Robot, fake: FakeLLM) -> None:
    fake.reply(Turn(text="I will look around, then move to the Kitchen Table."), Turn(tool_calls=[END]))
    trace = Trace()
    result, _ = await episode(robot, _settings(fake), trace)
    assert result.text_tool_calls == 0 and classify(trace.events)["parse"] == 0 and slips(trace.events) == {}


async def test_a_turn_cut_at_the_token_limit_is_kept_and_counted_apart(robot: Robot, fake: FakeLLM) -> None:
    fake.reply(Turn(text="First I will", finish_reason="length"), Turn(tool_calls=[END]))
    trace = Trace()
    result, _ = await episode(robot, _settings(fake), trace)
    assert result.outcome == "ended"
    turns = [e for e in trace.events if isinstance(e, ModelTurn)]
    assert [t.finish_reason for t in turns] == ["length", "tool_calls"]
    assert slips(trace.events) == {"cut_at_token_limit": 1} and classify(trace.events)["parse"] == 0


# --- the command line: errors read as errors, text tool calls said in one line --------------------


def _run_cli(fake: FakeLLM, tmp_path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in KEY_VARIABLES}
    command = [sys.executable, "-m", "robocog.agent.cli", "run", "T1", "--model", LOCAL]
    command += ["--api-base", fake.api_base(LOCAL), "--data-dir", str(tmp_path / "memory"), *extra]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)


def test_an_errored_run_prints_error_never_failure_and_the_error_once(fake: FakeLLM, tmp_path: Path) -> None:
    fake.script = lambda request: Fail(500, TEMPLATE_ERROR)
    done = _run_cli(fake, tmp_path)
    assert done.returncode == 1
    assert "Test results for task T1: error (the attempt did not finish)" in done.stdout
    assert "failure" not in done.stdout
    assert (done.stdout + done.stderr).count(TEMPLATE_ERROR) == 1, done.stdout + done.stderr
    assert len(fake.model_requests) == 2


def test_a_run_says_in_one_line_that_the_model_wrote_tool_calls_as_text(fake: FakeLLM, tmp_path: Path) -> None:
    calls = '<tool_call>{"name": "look_around", "arguments": {}}</tool_call>'

    def script(request: Request) -> Turn:
        done = any(m["role"] == "tool" for m in request.messages)
        return Turn(tool_calls=[END]) if done or len(fake.model_requests) > 2 else Turn(text=calls + calls)

    fake.script = script
    done = _run_cli(fake, tmp_path, "--quiet")
    said = [line for line in done.stderr.splitlines() if "as text" in line]
    assert said == [
        f"robocog: {LOCAL} wrote 4 tool calls as text, not run; the server may not parse tool calls "
        "(docs/models.md, 'When a local model writes its tool calls as text')"
    ], done.stderr
