"""How many fleets a study on fleets spawns unless told (`agent/harness/fleets.py`): one per core, and
more when that would put over 16 robots in each (a fleet runs one robot's call at a time)."""

from __future__ import annotations

from pathlib import Path

import anyio
import pytest

from robocog.agent.harness import fleets
from robocog.agent.harness.fleets import ROBOTS_PER_PROCESS, Fleets, default_processes


@pytest.mark.parametrize(
    ("cores", "workers", "expected"),
    [(2, 1, 2), (2, 16, 2), (2, 32, 2), (2, 33, 3), (2, 64, 4), (8, 64, 8), (8, 200, 13), (1, 17, 2)],
)
def test_one_fleet_per_core_and_more_for_many_workers(
    monkeypatch: pytest.MonkeyPatch, cores: int, workers: int, expected: int
) -> None:
    monkeypatch.setattr(fleets.os, "cpu_count", lambda: cores)
    assert default_processes(workers) == expected
    assert ROBOTS_PER_PROCESS == 16


def test_the_fleets_of_a_study_follow_the_default_never_past_the_workers(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(fleets.os, "cpu_count", lambda: 2)
    many = Fleets(64, tmp_path)
    assert (many.processes, many.robots) == (4, 17)  # 16 robots each, and one to spare
    assert Fleets(1, tmp_path).processes == 1  # never more fleets than workers
    assert Fleets(64, tmp_path, processes=2).processes == 2  # as told


#: A "fleet server" that listens on the port it is given and dies a moment later.
SHORT_LIVED = """
import socket, sys, time
port = int(sys.argv[sys.argv.index("--port") + 1])
with socket.create_server(("127.0.0.1", port)):
    print("listening, and dying soon", flush=True)
    time.sleep(0.2)
"""


@pytest.mark.anyio
async def test_a_fleet_that_keeps_dying_is_started_again_a_few_times_then_not(tmp_path: Path) -> None:
    import sys

    from robocog.shared.errors import ServerConnectionError

    script = tmp_path / "dies.py"
    script.write_text(SHORT_LIVED, encoding="utf-8")
    async with Fleets(1, tmp_path, processes=1, server_command=[sys.executable, str(script)]) as spawned:
        proc = spawned._procs[0]
        for _ in range(fleets.MAX_RESTARTS):
            assert proc is not None and proc.wait(timeout=10) == 0
            await spawned.ensure(0)  # started again: it listens again
            assert spawned._procs[0] is not proc
            proc = spawned._procs[0]
        assert proc is not None and proc.wait(timeout=10) == 0
        with pytest.raises(ServerConnectionError, match=r"died 4 times within 60 s and is not started again") as why:
            await spawned.ensure(0)
    assert "listening, and dying soon" in str(why.value)  # the end of its log says what it did


#: A "fleet server" that stops listening a moment after it starts and exits a second later (as a
#: killed process is gone from the network before it is reaped).
SLOW_TO_DIE = """
import socket, sys, time
port = int(sys.argv[sys.argv.index("--port") + 1])
with socket.create_server(("127.0.0.1", port)):
    time.sleep(0.3)
time.sleep(1.0)
"""


@pytest.mark.anyio
async def test_a_fleet_that_refuses_connections_while_it_exits_is_waited_for_and_started_again(tmp_path: Path) -> None:
    import sys

    script = tmp_path / "slow.py"
    script.write_text(SLOW_TO_DIE, encoding="utf-8")
    async with Fleets(1, tmp_path, processes=1, server_command=[sys.executable, str(script)]) as spawned:
        first = spawned._procs[0]
        while not fleets.refused(spawned.ports[0]):  # no longer listening, still running
            await anyio.sleep(0.05)
        assert first is not None and first.poll() is None
        await spawned.ensure(0)
        assert first.poll() is not None, "waited for it to exit"
        assert spawned._procs[0] is not first and not fleets.refused(spawned.ports[0])
