"""Hostile scene files against a real `robocog-server` process, and a robot action that runs past its
bounds or loses its client: each scene is refused at load in one line with exit status 2 (never an
abort, never minutes of building), a drive too long for one action is refused before the robot moves,
and a server whose stdio client has gone in the middle of a drive stops the drive and exits."""

from __future__ import annotations

import json
import os
import select
import subprocess
import time
from pathlib import Path

import pytest

from tests.e2e.test_attack import RawStdioServer
from tests.helpers import server_command, server_env
from tests.hostile_scenes import HOSTILE, write_all, write_far_corridor

#: Longer than this, a refusal is a hang (not a timing figure: `make bench BENCH_ONLY=edges` has those).
HANG_S = 120


@pytest.fixture(scope="module")
def hostile(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    return write_all(tmp_path_factory.mktemp("hostile"))


@pytest.mark.parametrize("name", [*HOSTILE, "huge_file", "robot_link"])
def test_a_hostile_scene_is_refused_at_load_in_one_line(name: str, hostile: dict[str, tuple[Path, str]]) -> None:
    path, words = hostile[name]
    done = subprocess.run(
        [*server_command(), "--scene", str(path)],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        env=server_env(),
        timeout=HANG_S,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"robocog-server: {path}: "), lines[0]
    assert words in lines[0], lines[0]


def test_the_robot_file_outside_the_scene_folder_is_never_opened(hostile: dict[str, tuple[Path, str]]) -> None:
    """The refusal names the path, not what the file holds (/etc/passwd is not parsed as YAML)."""
    path, _ = hostile["robot_escapes"]
    done = subprocess.run(
        [*server_command(), "--scene", str(path)], capture_output=True, text=True, env=server_env(), timeout=HANG_S
    )
    assert "root:" not in done.stderr and "expected a mapping" not in done.stderr, done.stderr


def test_a_drive_longer_than_an_action_may_take_is_refused_before_the_robot_moves(tmp_path: Path) -> None:
    scene = write_far_corridor(tmp_path / "corridor.yaml")
    server = RawStdioServer("--scene", str(scene), "--data-dir", str(tmp_path / "memory"), log=tmp_path / "server.log")
    try:
        answer = server.answer(server.send("tools/call", {"name": "move_to", "arguments": {"location": "Far C"}}))
        result = answer["result"]
        assert result["isError"], answer
        text = result["content"][0]["text"]
        assert "more than the 100,000 one action may take; nothing moved" in text, text
        here = server.call("look_around")
        assert here["location"] == "Front Door", here
        moved = server.call("move_to", location="Far A")  # within the bounds: the server carries on
        assert moved["location"] == "Far A", moved
    finally:
        server.close()


def test_a_server_whose_client_has_gone_stops_the_drive_and_exits(tmp_path: Path) -> None:
    """A drive of 60,000 steps (seconds of CPU) is under way when the client closes stdin: the drive
    stops at its next check (the log says so) and the process exits, instead of driving on orphaned."""
    scene = write_far_corridor(tmp_path / "corridor.yaml")
    log = tmp_path / "server.log"
    server = RawStdioServer("--scene", str(scene), "--data-dir", str(tmp_path / "memory"), log=log)
    params = {"name": "move_to", "arguments": {"location": "Far B"}, "_meta": {"progressToken": "drive"}}
    server.send("tools/call", params)
    _wait_for_progress(server)  # the robot has reached Far A: the call is running, 30,000 steps to go
    assert server.proc.stdin is not None
    server.proc.stdin.close()
    try:
        code = server.proc.wait(timeout=HANG_S)
    finally:
        server.close()
    assert code == 0
    said = log.read_text(encoding="utf-8", errors="replace")
    assert "move_to: the server is shutting down" in said, said[-2000:]  # the log wraps the rest of the line


def _wait_for_progress(server: RawStdioServer) -> None:
    """Read the server's messages until its first progress notification."""
    deadline = time.monotonic() + HANG_S
    while time.monotonic() < deadline:
        while b"\n" not in server.buffer:
            assert select.select([server.fd], [], [], HANG_S)[0], "no progress"
            chunk = os.read(server.fd, 1 << 20)
            assert chunk, "the server's stdout closed"
            server.buffer += chunk
        line, server.buffer = server.buffer.split(b"\n", 1)
        if line.strip() and json.loads(line).get("method") == "notifications/progress":
            return
    raise AssertionError("no progress notification")


def test_a_scene_within_the_bounds_still_loads(tmp_path: Path) -> None:
    """The corridor (a 1 ms step, locations 90 m out) is inside every bound: the server starts on it."""
    scene = write_far_corridor(tmp_path / "corridor.yaml")
    server = RawStdioServer("--scene", str(scene), "--data-dir", str(tmp_path / "memory"), log=tmp_path / "s.log")
    try:
        state = server.call("look_around")
        assert json.dumps(state)
    finally:
        server.close()
