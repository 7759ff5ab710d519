"""The two evaluation protocols, seen from the model's side of a real provider route.

The planner answers over loopback HTTP (tests/fake_llm/), so every request the harness sent is
recorded: the conversation shape, the task messages, the system prompt, what search_memory and the
scratchpad returned. Each protocol runs a whole study (T1 then T2, four memory iterations).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import pytest

from robocog.agent.harness.study import run_eval
from robocog.agent.study_protocols import task_of
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec
from robocog.shared.protocol import PAPER_TOOLS
from tests.fake_llm import PLACEHOLDER_KEY, FakeLLM, Request, planner_script
from tests.helpers import T1, T2

pytestmark = pytest.mark.anyio

LOCATIONS = ["Front Door", "Hallway Area Door", "Kitchen Door", "Kitchen Shelf", "Kitchen Table", "Living Room TV"]


@pytest.fixture(scope="module")
def fake() -> Iterator[FakeLLM]:
    with FakeLLM(planner_script()) as server:
        yield server


async def study(
    fake: FakeLLM, protocol: Literal["paper", "robocog"], out: Path
) -> tuple[list[AttemptRow], list[Request]]:
    fake.reset()
    config = EvalConfig(
        name=f"protocol-{protocol}",
        protocol=protocol,
        models=[ModelSpec(model="openai/planner", api_base=fake.openai_base, api_key=PLACEHOLDER_KEY)],
        tasks=["T1", "T2"],
        trials=1,
        memory_iterations=4,
    )
    rows = await run_eval(config, out)
    return rows, list(fake.model_requests)


def current_task(request: Request) -> str:
    users = [m for m in request.body["messages"] if m["role"] == "user"]
    return task_of(str(users[-1]["content"]))


def attempts(requests: list[Request]) -> list[list[Request]]:
    """The requests grouped by attempt: a new attempt starts when the current task changes or the
    conversation starts again."""
    groups: list[list[Request]] = []
    for r in requests:
        if groups:
            previous = groups[-1][-1]
            fresh = len(r.body["messages"]) <= len(previous.body["messages"])
            if not fresh and current_task(r) == current_task(previous):
                groups[-1].append(r)
                continue
        groups.append([r])
    return groups


def tool_results(group: list[Request], name: str) -> list[dict[str, Any]]:
    """The results of this attempt's own calls to `name` (its first request ends with its task message)."""
    begin = len(group[0].body["messages"]) - 1
    messages = group[-1].body["messages"][begin:]
    ids = {
        c["id"]
        for m in messages
        if m["role"] == "assistant"
        for c in m.get("tool_calls") or []
        if c["function"]["name"] == name
    }
    return [json.loads(m["content"]) for m in messages if m["role"] == "tool" and m["tool_call_id"] in ids]


async def test_the_paper_protocol_continues_the_conversation_and_describes_the_world(
    fake: FakeLLM, tmp_path: Path
) -> None:
    rows, requests = await study(fake, "paper", tmp_path / "paper.jsonl")
    assert [(r.memory_iteration, r.task, r.true_success, r.protocol) for r in rows] == [
        (i, t, True, "paper") for i in range(4) for t in ("T1", "T2")
    ]
    groups = attempts(requests)
    assert [current_task(g[0]) for g in groups] == [T1, T2] * 4
    for t1, t2 in zip(groups[::2], groups[1::2], strict=True):
        # T2's first request holds T1's whole conversation, end_task included, under one system prompt.
        first = t2[0].body["messages"]
        assert first[: len(t1[-1].body["messages"])] == t1[-1].body["messages"]
        assert sum(m["role"] == "system" for m in first) == 1
        assert any(c["function"]["name"] == "end_task" for m in first for c in m.get("tool_calls") or [])
    # Every task message carries the environment description and the task in <task> tags.
    for r in requests:
        for m in (m for m in r.body["messages"] if m["role"] == "user"):
            assert "<task>" in m["content"] and all(loc in m["content"] for loc in LOCATIONS), m["content"]
    system = requests[0].body["messages"][0]["content"]
    assert "claim success" not in system and "cannot be grasped" not in system
    # The paper's models are offered the paper's eight tools, whatever the server publishes beyond them.
    assert all([t["function"]["name"] for t in r.body["tools"]] == list(PAPER_TOOLS) for r in requests)
    # Top 5: by the last iteration six reports are stored, and T1's search returns five.
    assert len(tool_results(groups[6], "search_memory")[0]["results"]) == 5
    # The scratchpad carries over from T1 into T2 (T1 wrote its plan first).
    assert tool_results(groups[1], "add_to_scratchpad")[0]["entries"] == 2


async def test_the_robocog_protocol_starts_each_task_afresh(fake: FakeLLM, tmp_path: Path) -> None:
    rows, requests = await study(fake, "robocog", tmp_path / "robocog.jsonl")
    assert [(r.task, r.true_success, r.protocol) for r in rows] == [
        (t, True, "robocog") for _ in range(4) for t in ("T1", "T2")
    ]
    groups = attempts(requests)
    for group, task in zip(groups, [T1, T2] * 4, strict=True):
        first = group[0].body["messages"]
        assert [m["role"] for m in first] == ["system", "user"] and first[1]["content"] == task
    assert len(tool_results(groups[6], "search_memory")[0]["results"]) == 3
    # Text only: no camera; and the household has nothing that opens: no open and close either.
    assert all([t["function"]["name"] for t in r.body["tools"]] == list(PAPER_TOOLS) for r in requests)
    assert tool_results(groups[1], "add_to_scratchpad")[0]["entries"] == 1


async def test_a_study_under_partial_observation_records_it_in_every_row(fake: FakeLLM, tmp_path: Path) -> None:
    fake.reset()
    config = EvalConfig(
        name="observe-room",
        models=[ModelSpec(model="openai/planner", api_base=fake.openai_base, api_key=PLACEHOLDER_KEY)],
        tasks=["T1"],
        trials=1,
        memory_iterations=1,
        observe="room",
    )
    rows = await run_eval(config, tmp_path / "room.jsonl")
    assert [(r.observe, r.outcome) for r in rows] == [("room", rows[0].outcome)] and rows[0].outcome != "error"
    looks = [
        json.loads(m["content"])
        for r in fake.model_requests
        for m in r.body["messages"]
        if m["role"] == "tool" and '"locations"' in str(m.get("content"))
    ]
    assert looks and all(look.get("observed") == "room" for look in looks)
    assert '"observe"' in (tmp_path / "room.jsonl").read_text()
    fake.reset()
    plain = await run_eval(config.model_copy(update={"observe": None}), tmp_path / "house.jsonl")
    assert plain[0].observe is None and '"observe"' not in (tmp_path / "house.jsonl").read_text()
