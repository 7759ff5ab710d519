"""The memory's storage failing under a real `robocog-server`: its data directory removed while it runs
(what a second study once did to a live one's scratch memory: "attempt to write a readonly database"),
or its file system full. end_task then fails with the reason, for the model and in the server's log,
never the SDK's bare "Error executing tool end_task"; the server keeps answering."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from robocog.agent.client.loop import run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.shared.protocol import MEMORY_FAILED
from robocog.shared.trace import ToolResult
from tests.e2e.test_attack import RawStdioServer
from tests.helpers import in_process_robot


def _end_task(server: RawStdioServer) -> dict[str, object]:
    arguments = {"status": "success", "description": "Put away all the items into the shelf.", "summary": "done"}
    answer = server.answer(server.send("tools/call", {"name": "end_task", "arguments": arguments}))
    result = answer["result"]
    assert isinstance(result, dict)
    return result


def test_end_task_on_a_removed_memory_says_why_and_the_server_goes_on(tmp_path: Path) -> None:
    data = tmp_path / "memory"
    log = tmp_path / "server.log"
    server = RawStdioServer("--profile", "eval", "--data-dir", str(data), log=log)
    try:
        server.call("begin_task", task_id="T1", episode_id="removed-1")
        first = _end_task(server)
        assert not first.get("isError"), first
        shutil.rmtree(data)  # as a sweep that took a live study for dead did
        server.call("begin_task", task_id="T1", episode_id="removed-2")
        failed = _end_task(server)
        assert failed["isError"], failed
        text = failed["content"][0]["text"]  # type: ignore[index]
        # The store's own reason ("attempt to write a readonly database" as a rule; Chroma's timing may
        # give another first): one line after the marker, never a bare "Error executing tool end_task".
        prefix = f"Error executing tool end_task: {MEMORY_FAILED}: "
        assert text.startswith(prefix) and text[len(prefix) :].strip() and "\n" not in text, text
        assert server.call("look_around")["location"] == "Front Door"  # the server keeps answering
    finally:
        server.close()
    said = log.read_text(encoding="utf-8", errors="replace")
    reason = text[len(prefix) :].split()  # the log wraps its lines: the reason's words, all of them
    assert MEMORY_FAILED in " ".join(said.split()) and all(w in said for w in reason), said[-3000:]
    assert "Traceback" not in said, said[-3000:]


@pytest.fixture
def full_disk(tmp_path: Path) -> Iterator[Path]:
    """A 4 MB RAM file system (mounted as root; the test skips where it cannot be)."""
    mount = tmp_path / "small"
    mount.mkdir()
    if (
        shutil.which("mount") is None
        or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=4M", "tmpfs", str(mount)], capture_output=True
        ).returncode
    ):
        pytest.skip("cannot mount a small tmpfs here (needs root): the full-disk fault is not made")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def test_end_task_on_a_full_disk_says_why_and_the_server_goes_on(tmp_path: Path, full_disk: Path) -> None:
    data = full_disk / "memory"
    log = tmp_path / "server.log"
    server = RawStdioServer("--profile", "eval", "--data-dir", str(data), log=log)
    try:
        server.call("begin_task", task_id="T1", episode_id="full-1")
        assert not _end_task(server).get("isError")
        with (full_disk / "filler").open("wb") as filler:  # the rest of the file system
            try:
                while True:
                    filler.write(b"\0" * 65536)
                    filler.flush()
            except OSError:
                pass
        server.call("begin_task", task_id="T1", episode_id="full-2")
        failed = _end_task(server)
        assert failed["isError"], failed
        text = failed["content"][0]["text"]  # type: ignore[index]
        assert text == f"Error executing tool end_task: {MEMORY_FAILED}: database or disk is full", text
        assert server.call("look_around")["location"] == "Front Door"
    finally:
        server.close()


@pytest.mark.anyio
async def test_the_agent_loop_ends_the_attempt_on_a_memory_failure_with_its_reason_and_no_retry(
    tmp_path: Path,
) -> None:
    """The scripted planner does T1 on a real in-process server whose memory was removed: the attempt
    errs once, with the reason, instead of the model calling end_task again and again."""
    data = tmp_path / "memory"
    async with in_process_robot(data) as robot:
        await robot.client.call_tool("begin_task", {"task_id": "T1"})
        shutil.rmtree(data)
        trace = Trace()
        settings = AgentSettings(model="scripted/planner")
        prompt = "Put away all the items into the shelf."
        result = await run_episode(
            robot.client, prompt, settings, trace, system_prompt=robot.system_prompt, tools=robot.tools
        )
    assert result.outcome == "error" and result.invocations == 1, result
    # The reason is the store's own, and which one comes first depends on Chroma's timing ("attempt to
    # write a readonly database", "Failed to get segments", ...): there is one, after the marker.
    assert result.error is not None and f"{MEMORY_FAILED}: " in result.error, result.error
    assert result.error.split(f"{MEMORY_FAILED}: ", 1)[1].strip(), result.error
    failed = [e for e in trace.events if isinstance(e, ToolResult) and e.is_error and MEMORY_FAILED in e.content]
    assert len(failed) == 1, failed
