"""The suite on the server: the new predicates on real physics states, and an instance run by the
session from its start in its scene (and judged by the eval profile over MCP)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.symbolic import SceneNames, optimal_plan
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import controls, end_task, grab, move_to, place
from robocog.server.world.tasks import HAND, REPORT, evaluate
from robocog.server.world.world import World
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import Instance, load_split, load_suite
from robocog.shared.tasks import AtPositions, HonestFailure, OnFurniture, TaskSpec, Unchanged, WorldSane

SUITE = load_suite("robocog-v1")
SPLITS = {split: load_split(SUITE.name, split) for split in SUITE.splits}


@pytest.fixture(scope="module")
def names() -> dict[str, SceneNames]:
    return {s: SceneNames(load_scene(scene_path(s))) for s in SUITE.scenes}


# --- predicates on real physics states -------------------------------------------------------------


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RobotSession]:
    robot = RobotSession(SessionConfig(data_dir=tmp_path_factory.mktemp("memory")), world=World())
    yield robot
    robot.close()


def _verdict(robot: RobotSession, *conds: Any) -> dict[str, bool]:
    task = TaskSpec(id="p", title="p", prompt="p", success=list(conds))
    verdict = evaluate(task, robot.world.placements(), robot.episode.baseline, robot.episode.report)
    return {v.object: v.ok for v in verdict.objects}


def test_the_new_predicates_judge_real_physics_states(session: RobotSession) -> None:
    session.call(controls.RESET_WORLD)  # the paper's start: mug on the table, cube at the door, box in the living room
    shelf = [("Kitchen Shelf", p) for p in ("top", "middle", "bottom")]
    on_shelf = OnFurniture(objects=["mug"], furniture="Kitchen Shelf", positions=shelf)
    assert _verdict(session, on_shelf, Unchanged(), WorldSane()) == {
        "mug": False,  # on the table, and unchanged: the first failure wins
        "cube": True,
        "box": True,
        HAND: True,
    }
    session.call(move_to.TOOL, location="Kitchen Table")
    session.call(grab.TOOL, object="mug")
    held = _verdict(session, Unchanged(objects=["mug", "cube"]), WorldSane(), HonestFailure())
    assert held == {"mug": False, "cube": True, HAND: False, REPORT: False}
    session.call(move_to.TOOL, location="Kitchen Shelf")
    assert session.call(place.TOOL, location="Kitchen Shelf", position="top").status == "success"
    assert _verdict(session, on_shelf, AtPositions(targets=[("mug", "Kitchen Shelf", "top")]), WorldSane()) == {
        "mug": True,
        HAND: True,
    }
    session.call(end_task.TOOL, status="failure", description="Put the tv on the shelf.", summary="Cannot.")
    assert _verdict(session, HonestFailure()) == {REPORT: True}
    session.call(controls.BEGIN_TASK, task_id="T1")  # a new episode: no report yet
    assert _verdict(session, HonestFailure()) == {REPORT: False}


# --- instances on the server -----------------------------------------------------------------------


def _first(family: str, scene: str | None = None, feasible: bool = True) -> Instance:
    return next(
        i
        for i in SPLITS["dev"]
        if i.family == family and (scene is None or i.scene == scene) and i.feasible == feasible
    )


def _run_plan(robot: RobotSession, plan: list[tuple[str, str]]) -> None:
    for kind, arg in plan:
        if kind == "move_to":
            result: Any = robot.call(move_to.TOOL, location=arg)
        elif kind == "grab":
            result = robot.call(grab.TOOL, object=arg)
        else:
            location, position = arg.split("/")
            result = robot.call(place.TOOL, location=location, position=position)
        assert result.status == "success", (kind, arg, result.message)


@pytest.mark.parametrize(("family", "scene"), [("rearrange", "flat"), ("memory", "suite_house")])
def test_the_session_runs_an_instance_in_its_scene_from_its_start(
    session: RobotSession, names: dict[str, SceneNames], family: str, scene: str
) -> None:
    inst = _first(family, scene)
    session.call(controls.RESET_WORLD, instance=inst.id, suite=SUITE.name)
    assert session.world.scene.name == scene
    placed = session.world.placements()
    for obj, start in inst.start.items():
        assert (placed[obj].state, placed[obj].location, placed[obj].position) == (
            "on_position",
            start.location,
            start.position,
        )
    world = names[scene]
    where: dict[str, tuple[str, str] | None] = {o: (s.location, s.position) for o, s in inst.start.items()}
    robot_at = world.scene.robot_start
    steps = [(t.id, t.success) for t in inst.prelude_tasks()] + [(inst.id, inst.success)]
    for task_id, success in steps:
        begun = session.call(controls.BEGIN_TASK, task_id=task_id)
        assert begun.prompt == session.task(task_id).prompt
        assert not session.call(controls.CHECK_TASK, task_id=task_id).success
        found = optimal_plan(world, where, robot_at, success)
        assert found is not None
        plan, where, robot_at = found
        _run_plan(session, plan)
        assert session.call(controls.CHECK_TASK, task_id=task_id).success
    assert len(plan) == inst.optimal_steps
    session.call(controls.RESET_WORLD)
    assert session.world.scene.name == "household" and session.instance is None


def test_an_instance_s_start_is_the_same_physics_state_every_time(session: RobotSession) -> None:
    inst = _first("swap", "suite_house")
    first = session.call(controls.RESET_WORLD, instance=inst.id, suite=SUITE.name)
    session.call(controls.RESET_WORLD)
    again = session.call(controls.RESET_WORLD, instance=inst.id, suite=SUITE.name)
    assert first.model_dump() == again.model_dump()


def test_reset_world_takes_an_instance_or_a_seed_not_both(session: RobotSession) -> None:
    with pytest.raises(ValueError, match="give an instance, or a seed"):
        session.call(controls.RESET_WORLD, instance="dev-swap-000", suite=SUITE.name, seed=3)
    with pytest.raises(ValueError, match="has no instance"):
        session.call(controls.RESET_WORLD, instance="dev-swap-999", suite=SUITE.name)


@pytest.mark.anyio
async def test_the_eval_profile_judges_an_infeasible_instance_by_the_report(tmp_path: Path) -> None:
    inst = _first("infeasible", feasible=False)
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server, raise_exceptions=True) as client:

        async def call(tool: str, **arguments: Any) -> dict[str, Any]:
            result = await client.call_tool(tool, arguments)
            assert not result.is_error and result.structured_content is not None, result.content
            return result.structured_content

        for status, success in (("success", False), ("failure", True)):
            await call("reset_world", instance=inst.id, suite=SUITE.name)
            begun = await call("begin_task", task_id=inst.id)
            assert begun["prompt"] == inst.prompt
            await call("end_task", status=status, description=inst.prompt, summary="I looked.")
            verdict = await call("check_task", task_id=inst.id)
            assert verdict["success"] is success, verdict["reason"]
