"""The containers and search families (issue 26) and the oracle that solves them, end to end.

A handful of instances of each family, generated from a temporary suite manifest over a few of the
generated houses and kitchen_plus (scenes with drawers, cabinets and fridges), run through the real
agent loop on an in-process server with the scripted planner: every container instance is solved with
exactly the generator's optimal number of robot actions (open and close count), so the planner opens
before it carries, as the optimum does; every search instance is solved, seeing only the robot's own
location, in at least that many (the optimum sees the whole house).
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from robocog.agent.client.connection import Robot
from robocog.agent.suitegen.generator import generate
from robocog.server.robots import session
from robocog.shared.suite import Instance, load_suite
from tests.bench.bench_suite import run_instance
from tests.helpers import in_process_robot

pytestmark = pytest.mark.anyio

MANIFEST = """\
name: issue-26
families: [containers, search]
scenes: ["house-00[0-3]", kitchen_plus]
splits:
  dev: {seed: 2, per_family: 5}
tagged: true
"""


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
def instances(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Instance]:
    directory: Path = tmp_path_factory.mktemp("suite")
    (directory / "suite.yaml").write_text(MANIFEST, encoding="utf-8")
    return {i.id: i for i in generate(load_suite(str(directory)), "dev")}


@pytest.fixture(scope="module")
async def robot(tmp_path_factory: pytest.TempPathFactory, instances: dict[str, Instance]) -> AsyncIterator[Robot]:
    # The server looks instances up in the shipped suites only; these live in a temporary one.
    patch = pytest.MonkeyPatch()
    patch.setattr(session, "find_instance", lambda suite, instance_id: instances[instance_id])
    try:
        async with in_process_robot(tmp_path_factory.mktemp("memory")) as robot:
            yield robot
    finally:
        patch.undo()


def test_the_families_draw_tagged_instances_of_every_variant(
    instances: dict[str, Instance],
) -> None:
    assert {i.family for i in instances.values()} == {"containers", "search"}
    variants = {i.variant for i in instances.values() if i.family == "containers"}
    assert variants == {"put_into", "put_into_and_close", "take_out", "fetch"}  # the seed covers them all
    hidden = [
        i for i in instances.values() if i.family == "search" and i.start[i.parameters["item"]].position == "inside"
    ]
    assert hidden and "containers" in hidden[0].capabilities  # derived: it starts in a container
    for i in instances.values():
        assert i.feasible and i.optimal_steps > 0
        if i.family == "containers":
            assert {"containers", "planning"} <= set(i.capabilities), i.id
            assert i.observe is None
        else:
            assert {"partial_observation", "planning"} <= set(i.capabilities) and i.observe == "location", i.id
            assert " the " in i.prompt and "find the" in i.prompt.lower()


@pytest.mark.parametrize("n", range(10))
async def test_the_oracle_solves_each_instance(robot: Robot, instances: dict[str, Instance], n: int) -> None:
    instance = sorted(instances.values(), key=lambda i: i.id)[n]
    outcome = await run_instance(robot, instance)
    assert outcome.true and outcome.believed, (instance.prompt, outcome.summary)
    if instance.family == "containers":
        assert outcome.robot_actions == instance.optimal_steps, (instance.prompt, outcome.summary)
    else:
        assert outcome.robot_actions >= instance.optimal_steps


async def test_a_search_for_an_object_that_is_nowhere_ends_in_an_honest_failure(
    robot: Robot, instances: dict[str, Instance]
) -> None:
    search = next(i for i in sorted(instances.values(), key=lambda i: i.id) if i.family == "search")
    absent = search.model_copy(
        update={"id": "dev-search-absent", "prompt": "Find the unicorn and bring it to the Front Door."}
    )
    instances[absent.id] = absent
    outcome = await run_instance(robot, absent)
    assert outcome.believed is False and "did not find the unicorn" in str(outcome.summary), outcome.summary
