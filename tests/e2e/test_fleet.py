"""A fleet server (`robocog-server --robots N`): a robot per driver, private worlds, shared memory
by namespace, a cap, and robots that come back as good as new. One real HTTP server process for the
module; the pool's bookkeeping (idle drivers, recycling) also in process with a fake clock."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import anyio
import pytest
from mcp import Client

from robocog.agent.analysis.results_file import read_rows
from robocog.agent.harness.study import run_eval
from robocog.server.config import SessionConfig
from robocog.server.robots.fleet import Fleet, FleetFull
from robocog.server.robots.ownership import Driver
from robocog.shared.evaluation import AttemptRow, EvalConfig
from robocog.shared.protocol import DRIVER_META_KEY as DRIVER
from tests.helpers import call_ok, free_port, http_server, http_session, raw_answer, raw_initialize

pytestmark = pytest.mark.anyio

ROBOTS = 3


@pytest.fixture(scope="module")
def fleet_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("fleet")
    args = ["--profile", "eval", "--robots", str(ROBOTS), "--data-dir", str(tmp / "memory")]
    with http_server(tmp / "server.log", *args) as url:
        yield url


async def robot_location(client: Client) -> str:
    contents = (await client.read_resource("robocog://world/state")).contents
    return str(json.loads(contents[0].text)["robot"]["location"])  # type: ignore[union-attr]


async def test_each_session_drives_its_own_world(fleet_url: str) -> None:
    async with http_session(fleet_url) as a, http_session(fleet_url) as b:
        await call_ok(a, "move_to", location="Kitchen Table")
        await call_ok(a, "grab", object="mug")
        # b acts too (no lease between robots of a fleet) and sees its own, untouched world
        await call_ok(b, "move_to", location="Living Room")
        assert await robot_location(a) == "Kitchen Table"
        assert await robot_location(b) == "Living Room"
        seen = await call_ok(b, "look_around")
        assert "mug" in json.dumps(seen), "b's mug is still on b's kitchen table"
        await call_ok(a, "add_to_scratchpad", text="a's note")
        pad = await call_ok(b, "view_scratchpad")
        assert "a's note" not in json.dumps(pad)


async def test_memory_is_shared_by_namespace_and_private_otherwise(fleet_url: str) -> None:
    async with http_session(fleet_url) as a, http_session(fleet_url) as b:
        await call_ok(a, "reset_world", memory_namespace="fleet-trial-1")
        await call_ok(a, "clear_memory")
        await call_ok(b, "reset_world", memory_namespace="fleet-trial-2")
        await call_ok(b, "clear_memory")
        await call_ok(a, "end_task", status="failure", description="grasp the TV", summary="the TV is too heavy")
        found = await call_ok(b, "search_memory", query="grasp the TV")
        assert found["results"] == [], "another namespace: nothing of a's"
        await call_ok(b, "reset_world", memory_namespace="fleet-trial-1")
        found = await call_ok(b, "search_memory", query="grasp the TV")
        assert [r["summary"] for r in found["results"]] == ["the TV is too heavy"]


async def test_past_the_cap_a_session_is_told_why_and_a_freed_robot_comes_back_new(fleet_url: str) -> None:
    async with http_session(fleet_url) as a, http_session(fleet_url) as b, http_session(fleet_url) as c:
        for client in (a, b, c):
            await call_ok(client, "look_around")
        await call_ok(c, "move_to", location="Kitchen Door")
        await call_ok(c, "add_to_scratchpad", text="c was here")
        async with http_session(fleet_url) as d:
            refused = await d.call_tool("look_around", {})
            assert refused.is_error
            text = refused.content[0].text  # type: ignore[union-attr]
            assert f"all {ROBOTS} robots of this server are driven by other sessions" in text
    # all have gone; a newcomer gets one of their robots, recycled: the start state, an empty pad
    async with http_session(fleet_url) as e:
        for _ in range(50):  # a session's robot is freed just after its DELETE is answered
            result = await e.call_tool("view_scratchpad", {})
            if not result.is_error:
                break
            await anyio.sleep(0.1)
        assert not result.is_error, result.content
        assert "c was here" not in json.dumps(result.structured_content)
        assert await robot_location(e) == "Front Door"


async def test_a_bad_namespace_is_refused_with_what_a_namespace_may_be(fleet_url: str) -> None:
    async with http_session(fleet_url) as a:
        refused = await a.call_tool("reset_world", {"memory_namespace": "../etc"})
        assert refused.is_error
        assert "invalid memory namespace" in refused.content[0].text  # type: ignore[union-attr]
        await call_ok(a, "look_around")  # the robot is still fine


# --- a study on fleets gives the rows of a study on server processes ------------------------------------

#: What differs between two runs of the same study: how long things took, and where traces went.
TIMING = {"llm_latency_s", "wall_s", "trace"}
STUDY = {
    "name": "fleet",
    "models": [{"model": "scripted/overconfident", "params": {"p": 0.5}}],
    "tasks": ["T1"],
    "trials": 2,
    "memory_iterations": 2,
}


def outcome(rows: list[AttemptRow]) -> list[dict[str, Any]]:
    kept = [r.model_dump(exclude=TIMING) for r in rows]
    return sorted(kept, key=lambda r: (r["model"], r["trial"], r["memory_iteration"], r["task"]))


async def test_a_study_gives_the_same_rows_on_fleets_as_on_server_processes(fleet_url: str, tmp_path: Path) -> None:
    serial = await run_eval(EvalConfig.model_validate(STUDY | {"workers": 1}), tmp_path / "serial.jsonl")
    # a running fleet (--url), two workers at once on its robots
    on_url = await run_eval(EvalConfig.model_validate(STUDY | {"workers": 2}), tmp_path / "url.jsonl", urls=[fleet_url])
    assert len(serial) == 4 and not any(r.outcome == "error" for r in serial)
    assert outcome(on_url) == outcome(serial)
    # fleets the harness spawns, from the command line, as a user runs it
    config = tmp_path / "study.yaml"
    config.write_text(json.dumps(STUDY), encoding="utf-8")  # JSON is YAML
    out = tmp_path / "spawned.jsonl"
    command = [sys.executable, "-m", "robocog.agent.cli", "eval", str(config), "--out", str(out), "--quiet"]
    done = subprocess.run(
        [*command, "--isolation", "fleet", "--fleet-processes", "1", "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert outcome(read_rows(out)) == outcome(serial)


def fleet_children(parent: int) -> list[int]:
    """The fleet servers `parent` spawned (its children started with --robots)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
            argv = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:  # gone meanwhile
            continue
        ppid = next(int(line.split()[1]) for line in status.splitlines() if line.startswith("PPid:"))
        if ppid == parent and b"--robots" in argv:
            found.append(int(entry.name))
    return found


@pytest.mark.parametrize("when", ["mid-attempt", "between attempts"])
def test_a_fleet_that_dies_mid_study_is_started_again_and_the_study_goes_on(tmp_path: Path, when: str) -> None:
    """The fleet a study spawned is killed. Mid-attempt: that attempt is an error row naming the
    unreachable server (the transport fails the call, not the whole session) and --resume reruns it.
    Between attempts (after a row, in the unit's end or the next one's reset): the iteration runs on
    the fleet started again, with nothing lost. Either way the worker reconnects to the fleet started
    again on its port, and the other trials run."""
    config = tmp_path / "study.yaml"
    study = {"name": "dies", "models": [{"model": "scripted/planner"}], "tasks": ["T1"], "trials": 6}
    config.write_text(json.dumps(study | {"memory_iterations": 1}), encoding="utf-8")
    out = tmp_path / "rows.jsonl"
    third = tmp_path / "rows.traces" / "scripted_planner" / "trial-2" / "iter-0-T1.jsonl"

    def now() -> bool:
        if when == "mid-attempt":  # the third attempt has made a few calls, and has many left
            return third.exists() and third.read_text().count('"tool_call"') >= 3
        return out.exists() and len(out.read_text().splitlines()) >= 2

    command = [sys.executable, "-m", "robocog.agent.cli", "eval", str(config), "--out", str(out), "--quiet"]
    fleet = ["--isolation", "fleet", "--fleet-processes", "1", "--workers", "1"]
    proc = subprocess.Popen([*command, *fleet], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not now():
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.005)
        (killed,) = fleet_children(proc.pid)
        os.kill(killed, signal.SIGKILL)
        stdout, stderr = proc.communicate(timeout=180)
    finally:
        proc.kill()
    rows = read_rows(out)
    assert len(rows) == 6, stdout + stderr
    broken = [r for r in rows if r.outcome == "error"]
    assert all("is unreachable" in (r.error or "") for r in broken), broken
    assert len(broken) == 1 if when == "mid-attempt" else len(broken) <= 1  # the kill may land in the next attempt
    assert proc.returncode == (1 if broken else 0), stderr
    assert sum(r.true_success for r in rows) == 6 - len(broken)
    assert fleet_children(proc.pid) == []  # the restarted fleet was stopped with the study
    again = subprocess.run([*command, *fleet, "--resume"], capture_output=True, text=True, timeout=180)
    assert again.returncode == 0, again.stdout + again.stderr
    assert all(r.true_success for r in read_rows(out)) and len(read_rows(out)) == 6


async def test_a_study_drops_its_units_memory_namespaces_unless_told_to_keep_them(
    fleet_url: str, tmp_path: Path
) -> None:
    from robocog.agent.harness.units import unit_namespace

    async def records_left(study: str) -> int:
        async with http_session(fleet_url) as client:
            await call_ok(client, "reset_world", memory_namespace=unit_namespace(study, "scripted/overconfident", 0))
            return int((await call_ok(client, "clear_memory"))["removed"])

    one = STUDY | {"trials": 1, "memory_iterations": 1, "tasks": ["T1"]}
    await run_eval(EvalConfig.model_validate(one | {"name": "dropped"}), tmp_path / "a.jsonl", urls=[fleet_url])
    assert await records_left("dropped") == 0
    kept = one | {"name": "kept", "keep_memory": True}
    await run_eval(EvalConfig.model_validate(kept), tmp_path / "b.jsonl", urls=[fleet_url])
    assert await records_left("kept") == 1  # T1's report


# --- the pool's bookkeeping, in process ---------------------------------------------------------------


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


async def test_a_sessionless_drivers_robot_is_freed_after_it_goes_quiet(tmp_path: Path) -> None:
    clock = Clock()
    fleet = Fleet(SessionConfig(data_dir=tmp_path), capacity=2, idle_s=10, clock=clock)
    try:
        await anyio.to_thread.run_sync(fleet.build)
        one, two, three = (Driver(("driver", n), n, None) for n in ("one", "two", "three"))
        r1 = await fleet.robot_for(one)
        r2 = await fleet.robot_for(two)
        assert r1 is not r2 and await fleet.robot_for(one) is r1
        with pytest.raises(FleetFull):
            await fleet.robot_for(three)
        await r1.run(lambda s: s.world.drive(["Front Door", "Hallway Area Door"]))
        clock.now = 11  # one and two have both been quiet past idle_s
        r3 = await fleet.robot_for(three)
        assert r3 in (r1, r2) and fleet.in_use() == 1
        where = await r3.run(lambda s: s.world.robot_location())  # as its next driver reads it
        assert where == "Front Door", "recycled: back at the start"
        assert len(fleet.robots) == 2, "no robot built past the capacity"
    finally:
        fleet.close()


async def test_one_shared_robot_when_the_capacity_is_one(tmp_path: Path) -> None:
    fleet = Fleet(SessionConfig(data_dir=tmp_path), capacity=1)
    try:
        await anyio.to_thread.run_sync(fleet.build)
        robots = {id(await fleet.robot_for(Driver(("driver", n), n, None))) for n in "abc"}
        assert len(robots) == 1 and fleet.shared
    finally:
        fleet.close()


# --- a fleet in several processes behind one address ------------------------------------------------


async def test_a_fleet_in_two_processes_behind_one_address(tmp_path: Path) -> None:
    """Two robots in two processes (one each) behind a router: two sessions both drive (so they went
    to different processes: each has room for one), and share memory across the processes. With
    --json-response (as a harness starts its fleets) every call is answered with one JSON body."""
    args = ["--profile", "eval", "--robots", "2", "--processes", "2", "--data-dir", str(tmp_path / "memory")]
    with http_server(tmp_path / "server.log", *args, "--json-response") as url:
        async with http_session(url) as a, http_session(url) as b:
            await call_ok(a, "move_to", location="Kitchen Door")
            await call_ok(b, "move_to", location="Living Room")
            assert (await robot_location(a), await robot_location(b)) == ("Kitchen Door", "Living Room")
            await call_ok(a, "reset_world", memory_namespace="across")
            await call_ok(b, "reset_world", memory_namespace="across")
            await call_ok(a, "end_task", status="failure", description="grasp the TV", summary="it is too heavy")
            found = await call_ok(b, "search_memory", query="grasp the TV")
            assert [r["summary"] for r in found["results"]] == ["it is too heavy"]
            third = await anyio.to_thread.run_sync(raw_initialize, url)
            assert third.status_code == 503
            assert "all 2 robots of this server are driven by other sessions" in third.json()["error"]["message"]
        sid = (await anyio.to_thread.run_sync(raw_initialize, url)).headers["mcp-session-id"]
        answer = await anyio.to_thread.run_sync(lambda: raw_answer(url, sid, "look_around"))
        assert answer.headers["content-type"].startswith("application/json")
        assert answer.json()["result"]["structuredContent"]["status"] == "success"
    log = (tmp_path / "server.log").read_text(errors="replace")
    assert "2 robots in 2 processes" in log and "fleet process 2/2 ready" in log


async def test_the_lean_client_drives_a_json_fleet_as_the_sdk_s_does_and_frees_its_robot(tmp_path: Path) -> None:
    """robocog's lean client (`lean` over `json_http`, a study's own fleets) against a real
    `--json-response` server of one robot: the same answers as the SDK's client, and its session's
    DELETE frees the robot for the next driver at once (a session left open would hold it)."""
    from robocog.agent.client.connection import ServerSpec, connect

    args = ["--profile", "eval", "--robots", "1", "--max-sessions", "4", "--data-dir", str(tmp_path / "memory")]
    with http_server(tmp_path / "server.log", *args, "--json-response") as url:
        answers = []
        for lean in (True, False, True):
            async with connect(ServerSpec(url=url, lean=lean)) as robot:
                assert {"move_to", "grab", "reset_world", "check_task"} <= {t.name for t in robot.tools}
                assert robot.system_prompt and robot.tasks and robot.contract
                await robot.claim()
                await call_ok(robot.client, "reset_world", seed=3)
                await call_ok(robot.client, "move_to", location="Kitchen Table")
                answers.append(await call_ok(robot.client, "look_around"))
                async with http_session(url) as other:  # the only robot is taken
                    busy = await other.call_tool("move_to", {"location": "Living Room"})
                    assert busy.is_error, busy.content
        assert answers[0] == answers[1] == answers[2]


def test_the_router_splits_robots_and_arguments_and_keeps_a_sessionless_driver_in_place() -> None:
    from robocog.server.routing.router import Router, Upstream
    from robocog.server.routing.router_processes import passed_on, shares

    assert shares(5, 2) == [3, 2] and shares(4, 4) == [1, 1, 1, 1]
    argv = ["--transport", "http", "--port=9", "--robots", "8", "--processes", "2", "--profile", "eval", "--seed", "3"]
    assert passed_on(argv) == ["--profile", "eval", "--seed", "3"]
    router = Router([Upstream(0, 1, 2), Upstream(1, 2, 2)])
    call_by = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "tools/call", "params": {"_meta": {DRIVER: "me"}}})
    assert len({router.pick(call_by.encode()).index for _ in range(5)}) == 1, "always the same process"
    router.upstreams[0].active.add("s1")  # a session that made a call
    initialize = b'{"jsonrpc": "2.0", "id": 1, "method": "initialize"}'
    assert router.pick(initialize).index == 1, "the least loaded"
    router.upstreams[1].pending = 2  # a burst of new sessions not yet answered counts at once
    assert router.pick(initialize).index == 0


def test_the_router_checks_the_token_and_the_size_before_it_reads_on() -> None:
    from starlette.testclient import TestClient

    from robocog.server.routing.router import MAX_BODY, Router, Upstream

    router = Router([Upstream(0, free_port(), 1)], token="t" * 32)
    with TestClient(router.app()) as client:
        assert client.post("/mcp", content=b"{}").status_code == 401
        assert client.post("/mcp", content=b"{}", headers={"authorization": "Bearer wrong"}).status_code == 401
        big = client.post("/mcp", content=b"x" * (MAX_BODY + 1), headers={"authorization": "Bearer " + "t" * 32})
        assert big.status_code == 413
        unknown = client.post(
            "/mcp", content=b"{}", headers={"authorization": "Bearer " + "t" * 32, "mcp-session-id": "x"}
        )
        assert unknown.status_code == 404
