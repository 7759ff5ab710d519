"""How many fleets a study on fleets spawns unless told (`agent/harness/fleets.py`): one per core, and
more when that would put over 16 robots in each (a fleet runs one robot's call at a time)."""

from __future__ import annotations

from pathlib import Path

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
