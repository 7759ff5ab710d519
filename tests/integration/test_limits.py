"""Every text bounded: tool arguments refused at the edge, stored and returned texts cut by the memory."""

from __future__ import annotations

import types
import typing
from collections.abc import AsyncIterator, Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import chromadb
import pytest
from mcp import Client

from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.server.memory.embedding import embed
from robocog.server.memory.episodic import EpisodicMemory
from robocog.server.memory.scratchpad import Scratchpad
from robocog.server.robots.session import RobotSession
from robocog.server.tools import CONTROL_TOOLS, ROBOT_TOOLS, scratchpad, search_memory
from robocog.server.tools.base import Caller, Tool
from robocog.shared.limits import (
    DESCRIPTION_CHARS,
    EMBED_CHARS,
    SCRATCHPAD_CHARS,
    SCRATCHPAD_NOTES,
    SEARCH_ANSWER_CHARS,
    SUMMARY_CHARS,
    truncate,
)
from robocog.shared.memory_names import collection_name

TOOLS: tuple[Tool[Any], ...] = ROBOT_TOOLS + CONTROL_TOOLS
HUGE = 10_000_000


def _base(annotation: object) -> object:
    """The type under `Annotated[...]`."""
    return typing.get_args(annotation)[0] if typing.get_origin(annotation) is Annotated else annotation


def _is_text(annotation: object) -> bool:
    base = _base(annotation)
    return base is str or (isinstance(base, types.UnionType) and str in typing.get_args(base))


def _valid(annotation: object) -> object:
    """Some value the argument accepts (the other arguments of a call that tests one)."""
    base = _base(annotation)
    if typing.get_origin(base) is Literal:
        return typing.get_args(base)[0]
    if _is_text(annotation):
        return "T1"
    if base is bool:
        return False
    return 1


def _text_arguments() -> list[tuple[Tool[Any], str]]:
    return [(tool, p.name) for tool in TOOLS for p in tool.parameters if _is_text(p.annotation)]


def _arguments(tool: Tool[Any], name: str, value: str) -> dict[str, Any]:
    """Every required argument of `tool` valid, and `name` set to `value`."""
    arguments = {p.name: _valid(p.annotation) for p in tool.parameters if p.default is p.empty}
    return {**arguments, name: value}


@pytest.fixture
def invoked(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The tools whose code the session ran (the app calls `RobotSession.invoke` for every call)."""
    calls: list[str] = []
    original = RobotSession.invoke

    def spy(self: RobotSession, tool: Tool[Any], arguments: Mapping[str, Any], caller: Caller | None = None) -> Any:
        calls.append(tool.name)
        return original(self, tool, arguments, caller)

    monkeypatch.setattr(RobotSession, "invoke", spy)
    return calls


@pytest.fixture
async def robot(tmp_path: Path, invoked: list[str]) -> AsyncIterator[Client]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server, raise_exceptions=True) as client:
        yield client


# --- at the edge: every text argument of every tool ------------------------------------------------


def test_there_are_text_arguments_to_check() -> None:
    names = {(tool.name, name) for tool, name in _text_arguments()}
    assert {("end_task", "summary"), ("search_memory", "query"), ("begin_task", "episode_id")} <= names


def test_every_text_argument_has_a_limit_stated_in_its_tools_description() -> None:
    for tool, name in _text_arguments():
        limit = tool.text_limits.get(name)
        assert limit is not None, f"{tool.name}({name}) has no max_length"
        assert f"{name} at most {limit} characters" in tool.description, tool.name


@pytest.mark.anyio
async def test_an_oversize_text_is_refused_before_any_tool_code_runs(robot: Client, invoked: list[str]) -> None:
    schemas = {t.name: t.input_schema for t in (await robot.list_tools()).tools}
    for tool, name in _text_arguments():
        limit = tool.text_limits[name]
        schema = schemas[tool.name]["properties"][name]
        variants = [schema, *schema.get("anyOf", [])]
        assert limit in [s.get("maxLength") for s in variants], f"{tool.name}({name}): no maxLength in {schema}"
        for size in (limit + 1, HUGE):
            invoked.clear()
            result = await robot.call_tool(tool.name, _arguments(tool, name, "x" * size))
            text = " ".join(getattr(c, "text", "") for c in result.content)
            assert result.is_error, f"{tool.name}({name}) accepted {size} characters"
            assert invoked == [], f"{tool.name}({name}): the tool ran on {size} characters"
            assert name in text and f"too long: {size} characters, at most {limit} are accepted" in text, text
            assert len(text) < 1000, f"{tool.name}({name}): the error echoes the value"


@pytest.mark.anyio
async def test_bad_arguments_get_one_readable_line(robot: Client, invoked: list[str]) -> None:
    cases: dict[str, tuple[dict[str, Any], str]] = {
        "move_to": ({"location": 5}, "Invalid arguments for move_to: location: Input should be a valid string (got 5)"),
        "grab": ({}, "Invalid arguments for grab: object: Field required."),
        "search_memory": ({"query": "mug", "k": "x" * 500}, "k: Input should be a valid integer"),
    }
    for tool, (arguments, expected) in cases.items():
        result = await robot.call_tool(tool, arguments)
        text = " ".join(getattr(c, "text", "") for c in result.content)
        assert result.is_error and expected in text, text
        assert "pydantic" not in text and "Arguments" not in text and len(text) < 300, text
    assert invoked == []


@pytest.mark.anyio
async def test_a_text_at_its_limit_passes_the_edge(robot: Client, invoked: list[str]) -> None:
    for tool, name in _text_arguments():
        invoked.clear()
        result = await robot.call_tool(tool.name, _arguments(tool, name, "x" * tool.text_limits[name]))
        text = " ".join(getattr(c, "text", "") for c in result.content)
        assert "too long" not in text, f"{tool.name}({name}): {text[:300]}"
        assert invoked == [tool.name], f"{tool.name}({name}) did not run"


# --- stored and returned texts ---------------------------------------------------------------------


def test_truncate_keeps_short_texts_and_marks_cut_ones() -> None:
    assert truncate("short", 10) == "short"
    cut = truncate("y" * 100_000, 4000)
    assert len(cut) == 4000
    assert cut.startswith("yyy") and cut.endswith(" … [truncated, 100000 chars]")


def test_the_memory_stores_oversize_texts_cut_with_a_marker(tmp_path: Path) -> None:
    with EpisodicMemory(tmp_path / "mem") as memory:
        record = memory.add("put the mug away " + "d" * 50_000, "success", "s" * 50_000, model="m" * 5000)
        stored = memory.get(record.id)
    assert stored is not None and stored == record
    assert len(stored.task_description) == DESCRIPTION_CHARS and stored.task_description.startswith("put the mug")
    assert len(stored.summary) == SUMMARY_CHARS and stored.summary.endswith("[truncated, 50000 chars]")
    assert stored.model is not None and "[truncated, 5000 chars]" in stored.model


def _write_huge_records(data_dir: Path, namespace: str, n: int, size: int) -> None:
    """Records written straight through chromadb, as a robocog without limits would have stored them."""
    EpisodicMemory(data_dir, namespace=namespace).close()
    client = chromadb.PersistentClient(path=str(data_dir))
    collection = client.get_collection(collection_name(namespace))
    vector = embed(["put the mug in the sink"])[0]
    for i in range(n):
        collection.add(
            ids=[f"huge-{i}"],
            documents=["put the mug in the sink " + "d" * size],
            embeddings=[vector],
            metadatas=[
                {"believed_status": "failure", "summary": "s" * size, "created_at": "2025-01-01T00:00:00+00:00"}
            ],
        )


@pytest.mark.anyio
async def test_a_huge_record_from_before_the_limits_is_cut_in_search_answers(tmp_path: Path) -> None:
    config = SessionConfig(data_dir=tmp_path / "memory")
    _write_huge_records(config.data_dir or tmp_path, config.namespace, n=2, size=1_000_000)
    async with Client(build_server(config, profile="eval"), raise_exceptions=True) as client:
        result = await client.call_tool("search_memory", {"query": "put the mug in the sink", "k": 5})
    assert not result.is_error and result.structured_content is not None
    experiences = result.structured_content["results"]
    assert len(experiences) == 2
    for experience in experiences:
        assert len(experience["task_description"]) == DESCRIPTION_CHARS
        assert experience["summary"].endswith(" … [truncated, 1000000 chars]")
        assert len(experience["summary"]) == SUMMARY_CHARS
    assert len(getattr(result.content[0], "text", "")) < 2 * (DESCRIPTION_CHARS + SUMMARY_CHARS) + 1000


def test_a_search_answer_leaves_out_the_farthest_results_past_its_size(tmp_path: Path) -> None:
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    try:
        robot.memory.add_many(
            [
                {
                    "task_description": f"put item {i} away " + "d" * DESCRIPTION_CHARS,
                    "believed_status": "success",
                    "summary": "s" * SUMMARY_CHARS,
                }
                for i in range(20)
            ]
        )
        answer = robot.call(search_memory.TOOL, query="put an item away", k=20)
    finally:
        robot.close()
    fits = SEARCH_ANSWER_CHARS // (DESCRIPTION_CHARS + SUMMARY_CHARS)
    assert len(answer.results) == fits
    assert sum(len(e.task_description) + len(e.summary) for e in answer.results) <= SEARCH_ANSWER_CHARS
    assert f"{20 - fits} farther results were left out" in answer.message
    assert [e.distance for e in answer.results] == sorted(e.distance for e in answer.results)


def test_the_embedding_reads_a_bounded_prefix_of_a_text() -> None:
    text = "put the mug in the sink and then " * 40_000
    assert (embed([text]) == embed([text[:EMBED_CHARS]])).all()


def test_the_scratchpad_stays_within_its_caps_and_says_what_it_dropped(tmp_path: Path) -> None:
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    try:
        results = [robot.call(scratchpad.ADD, text=f"note {i} " + "n" * 1000) for i in range(SCRATCHPAD_NOTES)]
    finally:
        robot.close()
    assert robot.scratchpad.chars <= SCRATCHPAD_CHARS and len(robot.scratchpad) <= SCRATCHPAD_NOTES
    dropped = [r for r in results if r.dropped]
    assert dropped and all(f"The {r.dropped} oldest entries were dropped" in r.message for r in dropped)
    assert robot.scratchpad.entries[-1].startswith(f"note {SCRATCHPAD_NOTES - 1} ")
    pad = Scratchpad()
    for i in range(SCRATCHPAD_NOTES + 5):
        pad.add(f"short note {i}")
    assert len(pad) == SCRATCHPAD_NOTES and pad.entries[0] == "short note 5"
