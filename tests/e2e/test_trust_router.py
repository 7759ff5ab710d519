"""A router that heals: kill -9 of a routed fleet process is noticed, said in one line, and the
process restarted on its port and memory, so the fleet's capacity comes back; its lost sessions
are told so in one line; a SIGSTOPped process gets no new sessions and a timeout, not a hang;
hostile bodies (nested JSON, an oversized initialize) are refused cleanly. Real processes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx

from tests.helpers import HEADERS, INITIALIZE, fleet_processes, free_port, http_server_process, raw_call, raw_initialize


@contextmanager
def routed_fleet(tmp: Path, *args: str) -> Iterator[tuple[str, subprocess.Popen[bytes], Path]]:
    """`robocog-server --robots 2 --processes 2` on a free loopback port: its URL, the router's
    process and its log (the processes' logs go there too)."""
    log = tmp / "router.log"
    args = ("--robots", "2", "--processes", "2", "--profile", "eval", "--data-dir", str(tmp / "memory"), *args)
    with http_server_process(log, *args, timeout_s=120, env={"ROBOCOG_ROUTER_ANSWER_TIMEOUT_S": "3"}) as (url, proc):
        yield url, proc, log


def wait_for(condition: Any, proc: subprocess.Popen[bytes], log: Path, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert proc.poll() is None, log.read_text(errors="replace")[-3000:]
        assert time.monotonic() < deadline, log.read_text(errors="replace")[-3000:]
        time.sleep(0.1)


def open_session(url: str) -> str:
    """A session that made a call (it holds a robot): its id."""
    answer = raw_initialize(url)
    assert answer.status_code == 200, answer.text
    sid = str(answer.headers["mcp-session-id"])
    assert "Front Door" in raw_call(url, sid, "look_around")
    return sid


def test_kill_9_of_a_routed_process_is_healed_and_the_capacity_comes_back(tmp_path: Path) -> None:
    with routed_fleet(tmp_path) as (url, router, log):
        first, second = open_session(url), open_session(url)
        full = httpx.post(url, json=INITIALIZE, headers=HEADERS, timeout=30)
        assert full.status_code == 503 and "driven by other sessions" in full.text
        victim = fleet_processes(router.pid)[0]
        os.kill(victim, signal.SIGKILL)
        wait_for(lambda: "is back" in log.read_text(errors="replace"), router, log, 120)
        text = log.read_text(errors="replace")
        assert text.count("died (signal 9)") == 1 and "restarting it on port" in text
        assert "Traceback" not in text, "one line, not a traceback"
        # the session on the dead process is told what happened, once; the other drives on
        answers = {sid: raw_call(url, sid, "look_around") for sid in (first, second)}
        lost = [sid for sid, answer in answers.items() if answer.startswith("404")]
        assert len(lost) == 1 and "died and was restarted" in answers[lost[0]]
        survivor = next(sid for sid in answers if sid not in lost)
        assert answers[survivor].startswith("200") and "Front Door" in answers[survivor]
        # full capacity again: a new session gets the restarted process's robot
        assert "Front Door" in raw_call(url, open_session(url), "look_around")
        assert len(fleet_processes(router.pid)) == 2


def test_a_stopped_process_gets_no_new_sessions_and_its_requests_time_out(tmp_path: Path) -> None:
    with routed_fleet(tmp_path) as (url, router, log):
        sid = open_session(url)
        pids = fleet_processes(router.pid)
        os.kill(pids[0], signal.SIGSTOP)
        os.kill(pids[1], signal.SIGSTOP)
        try:
            wait_for(lambda: log.read_text(errors="replace").count("is stopped (SIGSTOP)") == 2, router, log, 30)
            refused = httpx.post(url, json=INITIALIZE, headers=HEADERS, timeout=30)
            assert refused.status_code == 503 and "stopped" in refused.text
            assert "driven by other sessions" not in refused.text.split("; the others")[0]
            answer = raw_call(url, sid, "look_around")  # its process is stopped: a timeout (3 s here), not a hang
            assert answer.startswith("502") and "did not answer within 3 s" in answer
        finally:
            for pid in pids:
                os.kill(pid, signal.SIGCONT)
        wait_for(lambda: log.read_text(errors="replace").count("runs again") == 2, router, log, 30)
        assert "Front Door" in raw_call(url, sid, "look_around")


def test_hostile_bodies_get_clear_answers_and_the_cap_holds_for_big_ones() -> None:
    from starlette.testclient import TestClient

    from robocog.server.routing.router import Router, Upstream

    router = Router([Upstream(0, free_port(), 1)])
    router.upstreams[0].active.add("busy")  # its one robot is taken
    with TestClient(router.app()) as client:
        nested = b"[" * 100_000 + b"]" * 100_000  # 200 KB
        answer = client.post("/mcp", content=nested, headers=HEADERS)
        assert answer.status_code == 400 and "nested too deeply" in answer.json()["error"]["message"]
        big = json.dumps(INITIALIZE | {"params": {**INITIALIZE["params"], "padding": "x" * 2_000_000}})  # type: ignore[dict-item]
        answer = client.post("/mcp", content=big, headers=HEADERS)
        assert answer.status_code == 503 and "driven by other sessions" in answer.json()["error"]["message"]
