"""A newcomer's mistakes, made as a newcomer makes them: each gets one true line, and bad input exits
2 before anything starts (no server, nothing stored in memory).

Every case runs the installed console scripts as subprocesses, the way the README has a user type them.
"""

from __future__ import annotations

import asyncio
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from robocog.agent.cli.preflight import looks_like_task_id, memory_records, unknown_task_id
from tests.helpers import http_server

BIN = Path(sys.executable).parent


def script(name: str) -> str:
    path = shutil.which(name, path=str(BIN))
    assert path is not None, f"{name} is not installed in {BIN}"
    return path


def call(
    program: str, *args: str | Path, stdin: str | None = None, timeout: float = 240
) -> subprocess.CompletedProcess[str]:
    unset = ("ROBOCOG_AUTH_TOKEN", "OPENAI_API_KEY")  # a newcomer has neither
    env = {k: v for k, v in os.environ.items() if k not in unset} | {"ANONYMIZED_TELEMETRY": "False"}
    return subprocess.run(
        [script(program), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        input=stdin,
        stdin=None if stdin is not None else subprocess.DEVNULL,
        env=env,
    )


def one_line(done: subprocess.CompletedProcess[str], program: str = "robocog") -> str:
    """The single line a mistake gets: exit 2, one line on stderr naming the program, no traceback."""
    assert done.returncode == 2, (done.returncode, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{program}: "), done.stderr
    return lines[0]


# --- task ids -----------------------------------------------------------------------------------------


def test_a_word_shaped_like_a_task_id_is_one() -> None:
    for word in ("T1", "t1", "T3", "task2", "dev-put_away-000"):
        assert looks_like_task_id(word)
    for words in ("Water the plants.", "Put the mug on the Kitchen Table.", "dance", "T1 please"):
        assert not looks_like_task_id(words)
    assert unknown_task_id("T1") is None and unknown_task_id("Water the plants.") is None
    assert "did you mean T1?" in (unknown_task_id("t1") or "")


@pytest.mark.parametrize(("word", "closest"), [("t1", "T1"), ("t2", "T2"), ("T3", "T1"), ("T12", "T1")])
def test_a_task_id_typo_exits_2_with_the_known_ids_before_anything_starts(
    tmp_path: Path, word: str, closest: str
) -> None:
    started = time.monotonic()
    line = one_line(call("robocog", "run", word, "--data-dir", tmp_path / "memory"))
    assert line.startswith(f"robocog: unknown task id {word!r}: the known task ids are T1, T2; did you mean {closest}?")
    assert not (tmp_path / "memory").exists()  # no server started, nothing stored
    assert time.monotonic() - started < 30


def test_a_study_with_an_unknown_task_id_exits_2_in_one_line(tmp_path: Path) -> None:
    config = tmp_path / "study.yaml"
    config.write_text("models: [{model: scripted/planner}]\ntasks: [T1, T3]\nout: r.jsonl\n", encoding="utf-8")
    line = one_line(call("robocog", "eval", config))
    assert line == f"robocog: {config}: tasks: unknown task id 'T3': the known task ids are T1, T2; did you mean T1?"
    assert not (tmp_path / "r.jsonl").exists()


# --- the model, the ports -----------------------------------------------------------------------------


def test_a_model_litellm_does_not_know_exits_2_before_the_server_starts(tmp_path: Path) -> None:
    done = call("robocog", "run", "T1", "--model", "gpt4o", "--data-dir", tmp_path / "memory")
    line = one_line(done)
    assert line.startswith(
        "robocog: --model gpt4o: LiteLLM does not know this model or its provider; did you mean gpt-4o?"
    )
    assert not (tmp_path / "memory").exists()
    line = one_line(call("robocog", "run", "T1", "--model", "gpt-4o", "--data-dir", tmp_path / "memory"))
    assert line == "robocog: model 'gpt-4o' needs OPENAI_API_KEY set in the environment (or give --api-key)"
    assert not (tmp_path / "memory").exists()


@contextmanager
def busy_port() -> Iterator[int]:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        yield int(sock.getsockname()[1])


def test_a_port_in_use_is_one_line_and_no_banner() -> None:
    with busy_port() as port:
        line = one_line(call("robocog-server", "--transport", "http", "--port", str(port)), "robocog-server")
        taken = f"cannot listen on 127.0.0.1:{port}: Address already in use; give another port"
        assert line == f"robocog-server: --port {port}: {taken}"
        served = call("robocog-server", "--view", str(port))  # the viewer is optional: the server serves on
        assert served.returncode == 0, served.stderr
        said = served.stderr.splitlines()
        assert said[0].startswith(f"robocog-server: the live viewer's port {port} is in use"), said
        line = one_line(call("robocog", "run", "T1", "--view", str(port)))
        assert line.startswith(f"robocog: --view {port}: 127.0.0.1:{port} is already in use")


# --- what a run says at its start, chat's empty line --------------------------------------------------


def test_each_run_names_its_memory_and_records_and_the_paper_protocol(tmp_path: Path) -> None:
    memory = tmp_path / "memory"
    first = call("robocog", "run", "T1", "--quiet", "--protocol", "paper", "--data-dir", memory)
    assert first.returncode == 0, first.stderr
    lines = first.stderr.splitlines()
    assert lines[0] == f"robocog: memory: {memory}, namespace default: 0 records from earlier runs"
    assert lines[1].startswith("robocog: protocol paper: the paper's messages and system prompt")
    assert memory_records(memory, "default") == 1
    # chat: a typo is answered at the prompt, and the empty line ends the session (T1 never runs again)
    chat = call("robocog", "chat", "--quiet", "--data-dir", memory, stdin="t1\n\nT1\n")
    assert chat.returncode == 0, chat.stderr
    assert chat.stderr.splitlines()[0] == (
        f"robocog: memory: {memory}, namespace default: 1 record from earlier runs "
        "(to start clean: --memory-namespace NEW-NAME, or --data-dir EMPTY-DIR)"
    )
    assert "robocog: unknown task id 't1': the known task ids are T1, T2; did you mean T1?" in chat.stderr
    assert "believed" not in chat.stdout  # nothing ran
    assert memory_records(memory, "default") == 1


# --- a server started by hand: no ground truth, a full fleet ------------------------------------------


async def hold_sessions(url: str, count: int, ready: asyncio.Event, done: asyncio.Event) -> None:
    """`count` MCP sessions over HTTP, each driving a robot (one look_around), held until `done`."""
    from contextlib import AsyncExitStack

    from mcp import Client
    from mcp.client.streamable_http import streamable_http_client

    async with AsyncExitStack() as stack:
        for _ in range(count):
            client = await stack.enter_async_context(Client(streamable_http_client(url), mode="legacy"))
            await client.call_tool("look_around", {})
        ready.set()
        await done.wait()


def test_url_without_ground_truth_says_so_and_a_full_fleet_is_one_line(tmp_path: Path) -> None:
    with http_server(tmp_path / "server.log", "--robots", "2", "--data-dir", str(tmp_path / "memory")) as url:
        done = call("robocog", "run", "T1", "--quiet", "--url", url)
        assert done.returncode == 0, done.stderr
        assert done.stderr.splitlines() == [
            f"robocog: the server at {url} has no ground truth for the client (it runs without --profile eval): "
            "no task is checked, and no 'Test results' line follows"
        ]

        async def third_client() -> subprocess.CompletedProcess[str]:
            ready, finished = asyncio.Event(), asyncio.Event()
            holder = asyncio.create_task(hold_sessions(url, 2, ready, finished))
            await asyncio.wait_for(ready.wait(), 60)
            try:
                return await asyncio.to_thread(call, "robocog", "run", "T1", "--quiet", "--url", url)
            finally:
                finished.set()
                await holder

        line = one_line(asyncio.run(third_client()))
        assert line.startswith(
            f"robocog: the robot server at {url}: all 2 robots of this server are driven by other sessions"
        )
    log = (tmp_path / "server.log").read_text(encoding="utf-8")
    assert "pybullet build time" not in log and "argv[0]=" not in log


# --- run --view: the page stays when the run ends -----------------------------------------------------


def test_run_view_keeps_the_viewer_until_ctrl_c(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "ROBOCOG_AUTH_TOKEN"} | {"ANONYMIZED_TELEMETRY": "False"}
    proc = subprocess.Popen(
        [script("robocog"), "run", "T1", "--quiet", "--view", "0", "--data-dir", str(tmp_path / "memory")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    try:
        assert proc.stderr is not None
        seen = []
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            seen.append(proc.stderr.readline())
            first = re.search(r"live viewer at (http://\S+/)", seen[-1])
            if first and len([line for line in seen if "live viewer at" in line]) == 1:
                with urllib.request.urlopen(first.group(1), timeout=5) as page:  # announced: it answers at once
                    assert page.status == 200
            if "stays at" in seen[-1] or not seen[-1]:
                break
        announced = re.search(r"live viewer at (http://127\.0\.0\.1:(\d+)/)", "".join(seen))
        assert announced and announced.group(2) != "0", seen  # the real port, never :0
        assert f"the live viewer stays at {announced.group(1)} until Ctrl-C" in seen[-1], seen
        time.sleep(2)  # well past the end of the run
        with urllib.request.urlopen(announced.group(1) + "api/state", timeout=10) as page:
            assert page.status == 200
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_the_console_names_the_papers_protocol() -> None:
    import io

    from robocog.agent.client.trace_sinks import Trace, make_console
    from robocog.shared.trace import RunStarted

    out = io.StringIO()
    trace = Trace(console=make_console(out))
    trace.emit(RunStarted(t=0, task="Put away.", model="scripted/planner", server="s", tools=[], protocol="paper"))
    trace.emit(RunStarted(t=0, task="Put away.", model="scripted/planner", server="s", tools=[]))
    assert out.getvalue().splitlines() == [
        '[SYSTEM] Executing prompt: "Put away." with scripted/planner under the paper protocol',
        '[SYSTEM] Executing prompt: "Put away." with scripted/planner',
    ]


def test_a_stdio_server_whose_stdin_is_the_null_device_ends_cleanly() -> None:
    # epoll refuses /dev/null, and uvloop's libuv aborted the process on it (SIGABRT, exit 134)
    ended = call("robocog-server")  # stdin the null device, stdout a pipe
    assert ended.returncode == 0, ended.stderr[-2000:]
