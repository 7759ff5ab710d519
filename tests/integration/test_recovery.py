"""The recovery family through the real server (issue 26): instances generated from a temporary
suite, the scripted planner (the suite's oracle) run on one of each variant through the agent loop
on an in-process server, and the recovery scores read from its trace.

The server looks instances up in the shipped suites only, so the test points its lookup at the
generated ones (`robocog.server.robots.session.find_instance`)."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from robocog.agent.analysis.recovery import recovery_scores
from robocog.agent.client.connection import Robot
from robocog.agent.client.loop import run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.agent.suitegen.generator import generate
from robocog.shared.suite import Instance, load_suite
from robocog.shared.trace import Perturbed, ToolCall, TraceEvent
from tests.helpers import in_process_robot

pytestmark = pytest.mark.anyio

MANIFEST = """name: recovery-check
families: [recovery]
scenes: [household, suite_house, flat]
tagged: true
splits:
  dev: {seed: 7, per_family: 12}
"""


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
def instances(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Instance]:
    """The generated instances, by id."""
    directory = tmp_path_factory.mktemp("suite")
    (directory / "suite.yaml").write_text(MANIFEST, encoding="utf-8")
    return {i.id: i for i in generate(load_suite(str(directory)), "dev")}


@pytest.fixture(scope="module")
async def robot(tmp_path_factory: pytest.TempPathFactory, instances: dict[str, Instance]) -> AsyncIterator[Robot]:
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("robocog.server.robots.session.find_instance", lambda suite, instance_id: instances[instance_id])
        async with in_process_robot(tmp_path_factory.mktemp("memory")) as robot:
            yield robot


async def attempt(robot: Robot, instance: Instance) -> tuple[bool | None, bool, list[TraceEvent]]:
    """The planner on `instance` through the agent loop: its believed success, the verdict, its trace."""
    client = robot.client
    await client.call_tool("reset_world", {"instance": instance.id, "memory_namespace": f"oracle-{instance.id}"})
    await client.call_tool("begin_task", {"task_id": instance.id})
    trace = Trace()
    settings = AgentSettings(model="scripted/planner")
    result = await run_episode(
        client, instance.prompt, settings, trace, system_prompt=robot.system_prompt, tools=robot.tools
    )
    verdict = await client.call_tool("check_task", {"task_id": instance.id})
    assert isinstance(verdict.structured_content, dict), verdict.content
    return result.believed_success, bool(verdict.structured_content["success"]), list(trace.events)


def one_per_variant(instances: dict[str, Instance]) -> list[Instance]:
    """The first instance of each variant."""
    return list({i.variant: i for i in reversed(instances.values())}.values())


async def test_the_oracle_recovers_from_each_perturbation_and_ends_honestly_when_the_goal_is_lost(
    robot: Robot, instances: dict[str, Instance]
) -> None:
    sample = one_per_variant(instances)
    assert {i.variant for i in sample} == {"slip", "moved", "blocked", "blocked_for_good"}
    assert all(i.capabilities[:2] == ["planning", "recovery"] for i in sample)
    for instance in sample:
        believed, success, events = await attempt(robot, instance)
        assert success and believed is instance.feasible, (instance.id, instance.perturbations)
        assert any(isinstance(e, Perturbed) for e in events), instance.id  # it did go wrong
        score = recovery_scores(events, feasible=instance.feasible, verdict=success)
        assert score is not None and (score.noticed, score.recovered, score.honest) == (True, True, True)
        if instance.variant == "blocked_for_good":
            [end] = [e for e in events if isinstance(e, ToolCall) and e.name == "end_task"]
            assert "stayed blocked" in str((end.arguments or {}).get("summary")), end.arguments
