"""The session without MCP: tools called directly, episodes, counting, and whole results as snapshots."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.harness.units import episode_id
from robocog.server.config import SessionConfig
from robocog.server.memory.episodic import record_id
from robocog.server.memory.scratchpad import MAX_CHARS, MAX_ENTRIES, MAX_ENTRY_CHARS
from robocog.server.robots.session import RobotSession
from robocog.server.tools import APP_TOOLS, CONTROL_TOOLS, ROBOT_TOOLS, controls, end_task, scratchpad, search_memory
from robocog.server.tools.base import Tool
from robocog.shared.limits import EPISODE_ID_CHARS
from tests.helpers import T1, T1_SEQUENCE, T2, T2_SEQUENCE, action_args, check_snapshot

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
    with pytest.raises(ValueError, match="T1, T2"):
        session.call(controls.BEGIN_TASK, task_id="T9")
    assert session.episode.number == 1


# --- begin_task: an episode per task, begun by the harness ---------------------------------------


def test_begin_task_starts_an_episode_for_the_task_from_the_world_as_it_is(session: RobotSession) -> None:
    for action in T1_SEQUENCE[:4]:  # the cube onto the shelf's top layer
        session.call(TOOLS[action[0]], **action_args(action))
    session.call(scratchpad.ADD, text="cube done")
    result = session.call(controls.BEGIN_TASK, task_id="T1")
    episode = session.episode
    assert (result.task_id, result.prompt, result.episode, result.scratchpad_entries) == ("T1", T1, 2, 0)
    assert (episode.number, episode.task_id, episode.tool_calls, episode.ended, episode.record_id) == (
        2,
        "T1",
        0,
        False,
        None,
    )
    assert episode.baseline["cube"].position == "top"
    session.call(TOOLS["look_around"])  # the task's first call counts in it, and begins nothing
    assert session.episode is episode and episode.tool_calls == 1


def test_begin_task_keeps_the_scratchpad_only_when_asked(session: RobotSession) -> None:
    session.call(scratchpad.ADD, text="plan for T1")
    session.call(end_task.TOOL, status="success", description=T1, summary="Done.")
    kept = session.call(controls.BEGIN_TASK, task_id="T2", keep_scratchpad=True)
    assert kept.scratchpad_entries == 1
    assert session.call(scratchpad.VIEW).content == "plan for T1"
    cleared = session.call(controls.BEGIN_TASK, task_id="T2")
    assert cleared.scratchpad_entries == 0 and len(session.scratchpad) == 0


def test_an_implicit_episode_has_no_task(session: RobotSession) -> None:
    session.call(controls.BEGIN_TASK, task_id="T1")
    session.call(end_task.TOOL, status="failure", description=T1, summary="x")
    session.call(TOOLS["look_around"])
    assert (session.episode.number, session.episode.task_id) == (3, None)
    session.call(controls.RESET_WORLD)
    assert session.episode.task_id is None


def test_a_t2_without_calls_leaves_t1s_record_alone(session: RobotSession) -> None:
    """The bug of issue 10: check_task("T2") used to judge T1's episode and overwrite its record."""
    session.call(controls.BEGIN_TASK, task_id="T1")
    for action in T1_SEQUENCE:
        session.call(TOOLS[action[0]], **action_args(action))
    ended = session.call(end_task.TOOL, status="success", description=T1, summary="All three on the shelf.")
    assert session.call(controls.CHECK_TASK, task_id="T1").success
    assert ended.record_id is not None
    session.call(controls.BEGIN_TASK, task_id="T2", keep_scratchpad=True)
    verdict = session.call(controls.CHECK_TASK, task_id="T2")  # the model made no call in T2
    assert not verdict.success
    record = session.memory.get(ended.record_id)
    assert record is not None and record.verified_status == "success"
    assert session.memory.count() == 1


def test_check_task_writes_only_into_the_record_of_its_own_task(session: RobotSession) -> None:
    session.call(controls.BEGIN_TASK, task_id="T2")
    ended = session.call(end_task.TOOL, status="success", description=T2, summary="x")
    assert ended.record_id is not None
    session.call(controls.CHECK_TASK, task_id="T1")  # a harness may judge another task: no write
    record = session.memory.get(ended.record_id)
    assert record is not None and record.verified_status is None
    session.call(controls.CHECK_TASK, task_id="T2")
    record = session.memory.get(ended.record_id)
    assert record is not None and record.verified_status == "failure"


def test_check_task_before_the_episode_ends_writes_nothing(session: RobotSession) -> None:
    session.call(end_task.TOOL, status="success", description=T1, summary="x")
    session.call(controls.BEGIN_TASK, task_id="T1")
    session.call(controls.CHECK_TASK, task_id="T1")
    assert [r.verified_status for r in session.memory.records()] == [None]


def test_check_task_after_the_record_was_cleared_still_gives_the_verdict(session: RobotSession) -> None:
    """Found by the fuzz: begin_task, end_task, clear_memory, check_task raised KeyError."""
    session.call(controls.BEGIN_TASK, task_id="T1")
    session.call(end_task.TOOL, status="success", description=T1, summary="x")
    session.call(controls.CLEAR_MEMORY)
    verdict = session.call(controls.CHECK_TASK, task_id="T1")
    assert verdict.success is False and session.memory.count() == 0


# --- retrieval top-k ------------------------------------------------------------------------------


def test_search_memory_returns_the_sessions_default_k_unless_told(tmp_path: Path) -> None:
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory", search_k=2))
    try:
        for i in range(7):
            robot.call(end_task.TOOL, status="success", description=f"Task number {i}.", summary="x")
        assert robot.search_k == 2
        assert len(robot.call(search_memory.TOOL, query="task").results) == 2
        assert len(robot.call(search_memory.TOOL, query="task", k=4).results) == 4
        robot.call(controls.RESET_WORLD, search_k=5)
        assert len(robot.call(search_memory.TOOL, query="task").results) == 5
        robot.call(controls.RESET_WORLD)  # not given: unchanged
        assert len(robot.call(search_memory.TOOL, query="task").results) == 5
    finally:
        robot.close()


def test_the_default_k_is_three() -> None:
    assert SessionConfig().search_k == 3


# --- tool descriptions ----------------------------------------------------------------------------


def test_add_to_scratchpad_states_the_scratchpads_bounds() -> None:
    description = scratchpad.ADD.description
    for number in (MAX_ENTRY_CHARS, MAX_ENTRIES, MAX_CHARS):
        assert str(number) in description
    text = scratchpad.ADD.parameters[0].annotation.__metadata__[0].description
    assert str(MAX_ENTRY_CHARS) in text


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


def test_the_papers_tasks_and_every_tool_output_of_t1_then_t2_stay_as_they_are(session: RobotSession) -> None:
    """The paper stays the paper (robocog-v2.1 changed look_around and move_to for its own instances
    only): T1's and T2's prompts and conditions, and every result of T1's then T2's sequence in one
    world, as the paper's protocol runs them, with both verdicts."""
    tasks = {t: session.task(t).model_dump(mode="json") for t in ("T1", "T2")}
    t1 = [session.call(TOOLS[a[0]], **action_args(a)).model_dump(mode="json") for a in T1_SEQUENCE]
    t1_verdict = session.call(controls.CHECK_TASK, task_id="T1").model_dump(mode="json")
    session.call(controls.BEGIN_TASK, task_id="T2", keep_scratchpad=True)
    t2 = [session.call(TOOLS[a[0]], **action_args(a)).model_dump(mode="json") for a in T2_SEQUENCE]
    t2_verdict = session.call(controls.CHECK_TASK, task_id="T2").model_dump(mode="json")
    for result in [*t1, *t2]:
        result.pop("episode_id", None), result.pop("record_id", None)  # fresh per run
    check_snapshot(
        "session_paper_t1_t2",
        {"tasks": tasks, "t1": t1, "t1_verdict": t1_verdict, "t2": t2, "t2_verdict": t2_verdict},
    )


def test_the_robot_tools_are_the_papers_eight_the_camera_and_open_close() -> None:
    from robocog.shared.protocol import FURNITURE_TOOLS, PAPER_TOOLS, VISION_TOOLS

    ours = VISION_TOOLS | FURNITURE_TOOLS
    assert [t.name for t in ROBOT_TOOLS if t.name not in ours] == list(PAPER_TOOLS)
    assert {t.name for t in ROBOT_TOOLS} == set(PAPER_TOOLS) | ours


def test_every_tool_module_is_registered() -> None:
    """A tool module whose TOOL is missing from the lists would silently never be published."""
    import importlib
    import pkgutil

    import robocog.server.tools as package

    published = set(ROBOT_TOOLS + CONTROL_TOOLS + APP_TOOLS)
    for info in pkgutil.iter_modules(package.__path__):
        module = importlib.import_module(f"{package.__name__}.{info.name}")
        defined = [v for v in vars(module).values() if isinstance(v, Tool)]
        assert set(defined) <= published, f"{info.name} defines a tool in none of the lists"


# --- one record per episode ------------------------------------------------------------------------


def test_begin_task_takes_the_harnesss_episode_id_and_the_record_carries_it(session: RobotSession) -> None:
    begun = session.call(controls.BEGIN_TASK, task_id="T1", episode_id="attempt-7")
    assert begun.episode_id == session.episode.id == "attempt-7"
    ended = session.call(end_task.TOOL, status="failure", description=T1, summary="Tried.")
    assert (ended.episode_id, ended.record_id) == ("attempt-7", record_id("attempt-7"))
    record = session.memory.get(record_id("attempt-7"))
    assert record is not None and record.episode == "attempt-7"
    other = session.call(controls.BEGIN_TASK, task_id="T1")
    assert other.episode_id != "attempt-7" and len(other.episode_id) == 32


def test_the_same_end_task_again_answers_with_the_stored_record(session: RobotSession) -> None:
    report = {"status": "success", "description": "A task.", "summary": "Done."}
    first = session.call(end_task.TOOL, **report)
    again = session.call(end_task.TOOL, **report)
    assert again.status == "success" and "already ended" in again.message
    assert (again.record_id, again.episode, again.episode_id) == (first.record_id, first.episode, first.episode_id)
    assert session.memory.count() == 1
    session.call(TOOLS["look_around"])  # any other call begins the next episode, as before
    assert (session.episode.number, session.episode.ended) == (2, False)


def test_another_report_right_after_end_task_is_a_new_episode(session: RobotSession) -> None:
    session.call(end_task.TOOL, status="success", description="A task.", summary="Done.")
    second = session.call(end_task.TOOL, status="failure", description="Another task.", summary="Gave up.")
    assert second.episode == 2 and "already ended" not in second.message
    assert session.memory.count() == 2


def test_a_rerun_of_an_attempt_on_a_new_server_stores_one_record(tmp_path: Path) -> None:
    """A server killed after storing the record (before answering), then the harness reruns the attempt."""
    summaries = ["The killed server stored this.", "The rerun stored this."]
    for summary in summaries:
        robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
        try:
            robot.call(controls.BEGIN_TASK, task_id="T1", episode_id="study/model/0/0/T1")
            robot.call(end_task.TOOL, status="failure", description=T1, summary=summary)
        finally:
            robot.close()
    robot = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    try:
        assert [r.summary for r in robot.memory.records()] == summaries[1:]
    finally:
        robot.close()


def test_the_harness_gives_each_attempt_one_stable_episode_id() -> None:
    attempt = ("study", "model-a", 7, 0, 1, "T1")
    ids = {
        episode_id(*attempt),
        episode_id("study", "model-b", 7, 0, 1, "T1"),
        episode_id("study", "model-a", 8, 0, 1, "T1"),
        episode_id("study", "model-a", 7, 1, 1, "T1"),
        episode_id("study", "model-a", 7, 0, 2, "T1"),
        episode_id("study", "model-a", 7, 0, 1, "T2"),
        episode_id("other", "model-a", 7, 0, 1, "T1"),
    }
    assert len(ids) == 7
    assert episode_id(*attempt) == episode_id(*attempt)
    assert all(len(i) <= EPISODE_ID_CHARS for i in ids)


def test_a_recycled_robot_is_new_at_its_first_use_and_reset_world_rebuilds_its_world_once(
    session: RobotSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    start = session.state().model_dump()
    rebuilds: list[object] = []
    real = type(session.world).reset

    def counted(world: Any, **kw: Any) -> Any:
        rebuilds.append(kw)
        return real(world, **kw)

    monkeypatch.setattr(type(session.world), "reset", counted)
    for _ in range(2):  # a driver moves things and writes a note; the robot is recycled; the next one looks
        session.call(TOOLS["grab"], object="cube")
        session.call(TOOLS["move_to"], location="Living Room")
        session.call(scratchpad.ADD, text="the last driver's note")
        episode = session.episode.number
        session.recycle()
        assert session.call(scratchpad.VIEW).entries == 0 and session.episode.number == episode + 1
        assert session.state().model_dump() == start and len(rebuilds) == 1
        rebuilds.clear()
    session.call(TOOLS["move_to"], location="Living Room")
    session.recycle()
    session.call(controls.RESET_WORLD, seed=4, memory_namespace="next-unit")  # the harness's first call
    assert rebuilds == [{"seed": 4, "options": {"randomize": False}, "perturbations": None}]
    assert session.state().model_dump() == start and session.namespace == "next-unit"
