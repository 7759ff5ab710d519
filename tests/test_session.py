"""The session without MCP: tools called directly, episodes, counting, and whole results as snapshots."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robocog.server.config import SessionConfig
from robocog.server.session import RobotSession
from robocog.server.tools import CONTROL_TOOLS, ROBOT_TOOLS, controls, end_task, scratchpad
from robocog.server.tools.base import Tool
from tests.helpers import T1_SEQUENCE, action_args, check_snapshot

TOOLS: dict[str, Tool[Any]] = {t.name: t for t in ROBOT_TOOLS + CONTROL_TOOLS}


@pytest.fixture
def session(tmp_path: Path) -> Iterator[RobotSession]:
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    yield robot
    robot.close()


def test_every_tool_has_a_title_a_description_annotations_and_a_result_model() -> None:
    for tool in TOOLS.values():
        assert tool.title and tool.description, tool.name
        assert tool.annotations.open_world_hint is False, tool.name
        assert "status" in tool.result_type.model_fields or tool.kind == "control", tool.name
        assert all(p.name != "robot" for p in tool.parameters), tool.name


def test_robot_tools_count_as_the_episodes_calls_and_controls_do_not(session: RobotSession) -> None:
    session.call(TOOLS["look_around"])
    session.call(TOOLS["move_to"], location="Living Room")
    session.call(controls.CHECK_TASK, task_id="T1")
    assert session.episode.tool_calls == 2
    result = session.call(end_task.TOOL, status="failure", description="Look around.", summary="Looked.")
    assert (result.episode, result.tool_calls) == (1, 3)


def test_the_first_call_after_end_task_starts_a_new_episode(session: RobotSession) -> None:
    session.call(scratchpad.ADD, text="episode one")
    session.call(end_task.TOOL, status="success", description="A task.", summary="Done.")
    assert session.episode.ended
    view = session.call(scratchpad.VIEW)
    assert (session.episode.number, session.episode.tool_calls, view.entries) == (2, 1, 0)


def test_reset_starts_a_new_episode_and_keeps_the_memory(session: RobotSession) -> None:
    session.call(end_task.TOOL, status="success", description="A task.", summary="Done.")
    session.call(controls.RESET_WORLD, seed=3)
    assert (session.episode.number, session.episode.tool_calls, session.episode.ended) == (2, 0, False)
    assert session.memory.count() == 1


def test_an_unknown_task_is_bad_input_naming_the_known_ones(session: RobotSession) -> None:
    with pytest.raises(ValueError, match="T1, T2"):
        session.call(controls.CHECK_TASK, task_id="T9")


def test_the_memory_opens_only_when_a_tool_needs_it(tmp_path: Path) -> None:
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    try:
        robot.call(TOOLS["look_around"])
        assert not (tmp_path / "memory").exists()
        robot.call(TOOLS["search_memory"], query="anything")
        assert (tmp_path / "memory").exists()
    finally:
        robot.close()


def test_t1_tool_results_match_the_snapshot(session: RobotSession) -> None:
    """Whole results of the deterministic T1 sequence: messages, paths, distances, occupants."""
    results = [session.call(TOOLS[a[0]], **action_args(a)).model_dump(mode="json") for a in T1_SEQUENCE]
    verdict = session.call(controls.CHECK_TASK, task_id="T1").model_dump(mode="json")
    check_snapshot("session_t1_results", {"results": results, "verdict": verdict})


def test_every_tool_module_is_registered() -> None:
    """A tool module whose TOOL is missing from the lists would silently never be published."""
    import importlib
    import pkgutil

    import robocog.server.tools as package

    published = set(ROBOT_TOOLS + CONTROL_TOOLS)
    for info in pkgutil.iter_modules(package.__path__):
        module = importlib.import_module(f"{package.__name__}.{info.name}")
        defined = [v for v in vars(module).values() if isinstance(v, Tool)]
        assert set(defined) <= published, f"{info.name} defines a tool that is not in ROBOT_TOOLS or CONTROL_TOOLS"
