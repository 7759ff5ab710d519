"""The information-fair oracle (issue 42): the planner learns each house only from what the tools say
(no scene file is read while it runs: the server runs in processes of its own, and every way this
process could read a scene is watched), and robocog-v2.1's perturbations meet an agent whatever order it
calls its tools in: the planner, the verbose order and the lean order each meet the perturbation
before their goal on every recovery instance sampled here (all of them: `make bench
BENCH_ONLY=suite_v21`)."""

from __future__ import annotations

import asyncio
import builtins
import io
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.analysis.recovery import met_before_goal, noticed
from robocog.agent.client.connection import Robot
from robocog.assets import ASSETS_DIR
from robocog.shared import scene_files
from robocog.shared.suite import Instance, load_split
from tests.bench.bench_suite import run_split
from tests.bench.bench_suite_v21 import traced_instance
from tests.helpers import in_process_robot

SUITE = "robocog-v2.1"
DEV = load_split(SUITE, "dev")
SCENES = (ASSETS_DIR / "scenes").resolve()


def _first_of_each(instances: list[Instance], family: str) -> list[Instance]:
    seen: dict[str, Instance] = {}
    for i in instances:
        if i.family == family:
            seen.setdefault(i.variant, i)
    return list(seen.values())


def spy_method(real: Any, watch: Any) -> Any:
    """A method of Path that tells `watch` which path it reads, then reads it."""

    def read(self: Path, *args: Any, **kwargs: Any) -> Any:
        watch(self)
        return real(self, *args, **kwargs)

    return read


def test_the_planner_reads_no_scene_file_while_it_solves_v2_1(monkeypatch: pytest.MonkeyPatch) -> None:
    read: list[str] = []

    def watch(path: Any) -> None:
        try:
            if Path(path).resolve().is_relative_to(SCENES):
                read.append(str(path))
        except (TypeError, ValueError, OSError):
            pass

    def spy(real: Any) -> Any:
        def opened(file: Any, *args: Any, **kwargs: Any) -> Any:
            watch(file)
            return real(file, *args, **kwargs)

        return opened

    monkeypatch.setattr(builtins, "open", spy(builtins.open))
    monkeypatch.setattr(io, "open", spy(io.open))
    for method in ("read_text", "read_bytes", "open"):
        monkeypatch.setattr(Path, method, spy_method(getattr(Path, method), watch))
    monkeypatch.setattr(scene_files, "load_scene", lambda *a, **k: pytest.fail("a scene was loaded"))
    sample = [*_first_of_each(DEV, "referring"), *_first_of_each(DEV, "infeasible"), *_first_of_each(DEV, "bring")]
    outcomes = asyncio.run(run_split(sample, 1, suite=SUITE))
    assert read == []
    assert [o.instance.id for o in outcomes if not o.ok] == []


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
async def robot(tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[Robot]:
    async with in_process_robot(tmp_path_factory.mktemp("memory")) as robot:
        yield robot


@pytest.mark.anyio
@pytest.mark.parametrize("model", ["scripted/planner", "scripted/verbose", "scripted/lean"])
@pytest.mark.parametrize("instance", _first_of_each(DEV, "recovery"), ids=lambda i: i.id)
async def test_every_order_of_calls_meets_the_perturbation_before_its_goal(
    robot: Robot, instance: Instance, model: str
) -> None:
    outcome, events = await traced_instance(robot, instance, model, suite=SUITE)
    assert met_before_goal(events), (instance.id, model)
    assert noticed(events), (instance.id, model)
    assert outcome.ok, (instance.id, model, outcome.summary)
