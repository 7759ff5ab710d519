"""The robocog suite: family and instance schemas, the seeded generator, the new predicates on real
physics states, and suite instances run on the server (the session and the eval profile over MCP)."""

from __future__ import annotations

import json
import random
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from pydantic import ValidationError

from robocog.agent.cli import main as cli
from robocog.agent.families import load_families, load_family
from robocog.agent.harness.study import run_eval
from robocog.agent.harness.suite_run import SuiteRun
from robocog.agent.suitegen.generator import derived_seed, generate
from robocog.agent.symbolic import SceneNames, holds, optimal_plan, solved, steps_after
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.server.session import RobotSession
from robocog.server.tools import controls, end_task, grab, move_to, place
from robocog.server.world.tasks import HAND, REPORT, evaluate
from robocog.server.world.world import World
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import EvalConfig, ModelSpec
from robocog.shared.results import ObjectPlacement
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import (
    SUITES_DIR,
    Instance,
    dump_instances,
    find_instance,
    load_split,
    load_suite,
    parse_instances,
    render_prompt,
    select,
)
from robocog.shared.tasks import (
    AtPositions,
    HonestFailure,
    OnFurniture,
    TaskSpec,
    Unchanged,
    WorldSane,
)

SUITE = load_suite()
SPLITS = {split: load_split(SUITE.name, split) for split in SUITE.splits}
INSTANCES = [i for split in SPLITS.values() for i in split]


@pytest.fixture(scope="module")
def names() -> dict[str, SceneNames]:
    return {s: SceneNames(load_scene(scene_path(s))) for s in SUITE.scenes}


# --- schemas ---------------------------------------------------------------------------------------

VALID_FAMILY = """\
id: {id}
title: Bring
description: Bring one item.
variants:
  - id: v
    draw: item_to_location
    prompt: Bring the {{item}} to the {{location}}.
    success:
      - kind: at_location
        objects: ["{{item}}"]
        location: "{{location}}"
"""


def _family_error(tmp_path: Path, text: str, stem: str = "fam") -> str:
    path = tmp_path / f"{stem}.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_family(path)
    return str(err.value)


def test_the_shipped_families_load_and_the_suite_names_only_them() -> None:
    families = load_families()
    assert (
        set(SUITE.families)
        == set(families)
        == {
            "put_away",
            "swap",
            "bring",
            "rearrange",
            "infeasible",
            "referring",
            "memory",
        }
    )
    assert families["infeasible"].feasible is False and families["bring"].feasible is True


def test_a_valid_family_loads(tmp_path: Path) -> None:
    path = tmp_path / "fam.yaml"
    path.write_text(VALID_FAMILY.format(id="fam"), encoding="utf-8")
    assert load_family(path).variants[0].draw == "item_to_location"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("{location}.", "{room}."), "prompt: unknown parameter(s) ['room']"),
        (("kind: at_location", "kind: on_shelf"), "does not match any of the expected tags"),
        (("draw: item_to_location", "draw: teleport"), "variants[0].draw: Input should be"),
        (("    success:", "    feasible: false\n    success:"), "an infeasible variant's success is an honest_failure"),
        (("title: Bring\n", ""), "title: Field required"),
        (("    prompt:", "    count: [1, 2]\n    prompt:"), "count: draw 'item_to_location' takes no count"),
        (("    prompt:", "    colour: red\n    prompt:"), "variants[0].colour: Extra inputs are not permitted"),
    ],
)
def test_a_malformed_family_is_one_line_naming_the_field(tmp_path: Path, change: tuple[str, str], message: str) -> None:
    text = VALID_FAMILY.format(id="fam")
    assert change[0] in text
    error = _family_error(tmp_path, text.replace(*change))
    assert message in error and "\n" not in error and "fam.yaml" in error


def test_a_family_s_id_is_its_file_name(tmp_path: Path) -> None:
    assert "must be the file's name" in _family_error(tmp_path, VALID_FAMILY.format(id="other"))


def test_instance_lines_are_validated_with_their_line_numbers() -> None:
    good = INSTANCES[0].model_dump_json()
    assert parse_instances(good + "\n\n", "x.jsonl") == [INSTANCES[0]]
    with pytest.raises(ConfigError, match=r"x.jsonl: line 2: not JSON"):
        parse_instances(good + "\n{oops\n", "x.jsonl")
    with pytest.raises(ConfigError, match=r"line 2: instance id .* is listed twice"):
        parse_instances(good + "\n" + good, "x.jsonl")
    broken = json.loads(good) | {"optimal_steps": -1}
    with pytest.raises(ConfigError, match=r"line 1: optimal_steps: Input should be greater than or equal to 0"):
        parse_instances(json.dumps(broken), "x.jsonl")


def test_prompts_write_lists_out() -> None:
    assert render_prompt("Put {items} on the {f}.", {"items": ["mug"], "f": "Shelf"}) == "Put the mug on the Shelf."
    assert render_prompt("{items}", {"items": ["a", "b", "c"]}) == "the a, the b and the c"
    targets = [["mug", "Shelf", "top"], ["cube", "Door", "floor"]]
    assert render_prompt("{t}.", {"t": targets}) == "the mug on Shelf top, the cube on Door floor."


# --- the generator ---------------------------------------------------------------------------------


def test_the_committed_dev_split_is_what_its_seed_generates_byte_for_byte() -> None:
    committed = (SUITES_DIR / SUITE.name / "dev.jsonl").read_bytes()
    assert dump_instances(generate(SUITE, "dev")).encode() == committed


def test_the_same_seed_gives_the_same_bytes_and_another_seed_other_instances() -> None:
    one = dump_instances(generate(SUITE, "test", seed=7, per_family=2))
    assert one == dump_instances(generate(SUITE, "test", seed=7, per_family=2))
    assert one != dump_instances(generate(SUITE, "test", seed=8, per_family=2))
    assert derived_seed("a", 1) == derived_seed("a", 1) != derived_seed("a", 2)


def test_the_splits_cover_every_family_and_scene_with_unique_ids() -> None:
    for split, instances in SPLITS.items():
        per = SUITE.splits[split].per_family
        assert [i.family for i in instances] == [f for f in SUITE.families for _ in range(per)]
        assert {i.scene for i in instances} == set(SUITE.scenes)
        assert all(i.split == split and i.id.startswith(f"{split}-{i.family}-") for i in instances)
    assert len({i.id for i in INSTANCES}) == len(INSTANCES)
    variants = {(f.id, v.id) for f in load_families().values() for v in f.variants}
    assert {(i.family, i.variant) for i in INSTANCES} == variants  # every variant is posed somewhere


def _placements(where: dict[str, tuple[str, str] | None]) -> dict[str, ObjectPlacement]:
    """Symbolic positions as the physics' placements (a held object: in the hand)."""
    return {
        o: ObjectPlacement(
            object=o,
            state="on_position" if w else "held",
            location=w[0] if w else None,
            position=w[1] if w else None,
            xyz=(0.0, 0.0, 0.0),
            resting=bool(w),
        )
        for o, w in where.items()
    }


@pytest.mark.parametrize("split", list(SUITE.splits))
def test_no_instance_is_solved_when_it_begins_and_an_optimal_plan_solves_it(
    split: str, names: dict[str, SceneNames]
) -> None:
    """On the server's own verdict: not solved at the task's start (after its earlier tasks); the
    generator's optimal plan, of `optimal_steps` actions, solves it; an infeasible task is solved by an
    honest report only."""
    for inst in SPLITS[split]:
        world = names[inst.scene]
        start: dict[str, tuple[str, str] | None] = {o: (s.location, s.position) for o, s in inst.start.items()}
        after = steps_after(world, start, world.scene.robot_start, inst.prelude)
        assert after is not None, inst.id
        now, robot, _ = after
        task = inst.task()
        before = _placements(now)
        assert not evaluate(task, before, before, None).success, inst.id
        if inst.feasible:
            found = optimal_plan(world, now, robot, inst.success)
            assert found is not None and len(found[0]) == inst.optimal_steps, inst.id
            end = _placements(found[1])
            assert evaluate(task, end, before, {"status": "success"}).success, inst.id
        else:
            assert inst.optimal_steps == 0
            assert evaluate(task, before, before, {"status": "failure"}).success, inst.id
            assert not evaluate(task, before, before, {"status": "success"}).success, inst.id


def test_the_symbolic_verdicts_agree_with_the_server_s(names: dict[str, SceneNames]) -> None:
    """Random states of every instance's objects: `holds` and the server's `evaluate` agree."""
    rng = random.Random(12)
    for inst in INSTANCES[::3]:
        spots = names[inst.scene].spots
        base: dict[str, tuple[str, str] | None] = {o: (s.location, s.position) for o, s in inst.start.items()}
        for _ in range(5):
            now: dict[str, tuple[str, str] | None] = dict(zip(base, rng.sample(spots, len(base)), strict=True))
            if rng.random() < 0.3:
                now[rng.choice(list(now))] = None
            for cond in inst.success:
                if isinstance(cond, HonestFailure):
                    continue
                task = TaskSpec(id="x", title="x", prompt="x", success=[cond])
                server = evaluate(task, _placements(now), _placements(base)).success
                assert holds(cond, now, base) == server, (inst.id, cond, now)


def test_optimal_plans_park_an_item_for_a_swap(names: dict[str, SceneNames]) -> None:
    world = names["household"]
    where: dict[str, tuple[str, str] | None] = {
        "cube": ("Kitchen Shelf", "top"),
        "mug": ("Kitchen Shelf", "middle"),
        "box": ("Living Room", "floor"),
    }
    cond = AtPositions(targets=[("cube", "Kitchen Shelf", "middle"), ("mug", "Kitchen Shelf", "top")])
    found = optimal_plan(world, where, "Kitchen Shelf", [cond])
    assert found is not None
    plan = found[0]
    # grab, place (park on the bottom layer), grab, place, grab, place: no move at all
    assert len(plan) == 6 and [a for a, _ in plan].count("move_to") == 0
    assert solved([cond], found[1], where)


def test_select_spreads_a_sample_over_the_families() -> None:
    chosen = select(SPLITS["dev"], limit=len(SUITE.families))
    assert sorted(i.family for i in chosen) == sorted(SUITE.families)
    assert [i.family for i in select(SPLITS["dev"], families=["swap"], limit=3)] == ["swap"] * 3
    with pytest.raises(ValueError, match="has no instance 'nope'"):
        find_instance(SUITE.name, "nope")
    for suite in ("nope", f"../suites/{SUITE.name}"):  # a name, never a path: clients name instances
        with pytest.raises(ValueError, match="unknown suite"):
            find_instance(suite, "dev-swap-000")


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


def test_new_predicates_on_physics_states(session: RobotSession) -> None:
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
    session.call(controls.RESET_WORLD, instance=inst.id)
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
    first = session.call(controls.RESET_WORLD, instance=inst.id)
    session.call(controls.RESET_WORLD)
    again = session.call(controls.RESET_WORLD, instance=inst.id)
    assert first.model_dump() == again.model_dump()


def test_reset_world_takes_an_instance_or_a_seed_not_both(session: RobotSession) -> None:
    with pytest.raises(ValueError, match="give an instance, or a seed"):
        session.call(controls.RESET_WORLD, instance="dev-swap-000", seed=3)
    with pytest.raises(ValueError, match="has no instance"):
        session.call(controls.RESET_WORLD, instance="dev-swap-999")


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


# --- a study over the suite ------------------------------------------------------------------------


def test_a_study_config_takes_a_suite_and_selects_its_instances() -> None:
    models = [ModelSpec(model="scripted/planner")]
    config = EvalConfig(models=models, suite=SUITE.name, split="test", instances=9, families=["swap", "memory"])
    assert config.tasks == [i.id for i in select(SPLITS["test"], families=["swap", "memory"], limit=9)]
    assert {t.split("-")[1] for t in config.tasks} == {"swap", "memory"}
    assert EvalConfig.model_validate(config.model_dump()).tasks == config.tasks  # a config read back
    for bad, message in (
        ({"suite": SUITE.name, "tasks": ["T1"]}, "either tasks or a suite's instances"),
        ({"instances": 3}, "give the suite"),
        ({"suite": SUITE.name, "families": ["juggling"]}, "no such family ['juggling']"),
        ({"suite": SUITE.name, "split": "holdout"}, "no such split"),
    ):
        with pytest.raises(ValidationError, match=re.escape(message)):
            EvalConfig.model_validate({"models": [{"model": "scripted/planner"}], **bad})


def test_the_runner_prompts_instances_and_their_earlier_tasks_and_labels_their_rows() -> None:
    config = EvalConfig(models=[ModelSpec(model="scripted/planner")], suite=SUITE.name, families=["memory"])
    run = SuiteRun.of(config)
    inst = run.instances[config.tasks[0]]
    assert run.prompt(inst.id) == inst.prompt and run.prompt(f"{inst.id}-pre1") == inst.prelude[0].prompt
    assert run.prompt(f"{inst.id}-pre2") is None and run.prompt("T1") is None
    assert run.row_fields(inst.id) == {
        "family": "memory",
        "instance": inst.id,
        "feasible": True,
        "optimal_steps": inst.optimal_steps,
    }
    assert run.row_fields("T1") == {} and SuiteRun.of(EvalConfig(models=config.models)).instances == {}


def test_robocog_suite_generates_and_lists(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mini.jsonl"
    assert cli.main(["suite", "generate", "--split", "test", "--seed", "3", "--per-family", "1", "-o", str(out)]) == 0
    mini = parse_instances(out.read_text(encoding="utf-8"), str(out))
    assert [i.family for i in mini] == SUITE.families
    assert cli.main(["suite", "list"]) == 0
    listed = capsys.readouterr().out
    assert all(f in listed for f in SUITE.families) and "Swap the mug and the cube." in listed
    assert cli.main(["suite", "list", "--split", "dev"]) == 0
    assert SPLITS["dev"][0].prompt in capsys.readouterr().out
    assert cli.main(["suite", "generate", "--split", "holdout"]) == 2
    assert "has no split 'holdout'" in capsys.readouterr().err


@pytest.mark.anyio
async def test_a_study_runs_an_instance_after_its_earlier_task_and_labels_the_row(tmp_path: Path) -> None:
    """One memory instance through `robocog eval`'s runner (a server process): the earlier task runs
    as its own traced episode, the instance's row carries its family and optimum."""
    config = EvalConfig(
        name="suite-test",
        models=[ModelSpec(model="scripted/planner")],
        suite=SUITE.name,
        families=["memory"],
        instances=1,
        trials=1,
        memory_iterations=1,
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    inst = find_instance(SUITE.name, config.tasks[0])
    assert [(r.task, r.family, r.instance, r.feasible, r.optimal_steps) for r in rows] == [
        (inst.id, "memory", inst.id, True, inst.optimal_steps)
    ]
    assert rows[0].true_success and rows[0].believed_success, rows[0].reason
    traces = sorted(p.name for p in (tmp_path / "r.traces").rglob("*.jsonl"))
    assert traces == [f"iter-0-{inst.id}-pre1.jsonl", f"iter-0-{inst.id}.jsonl"]


@pytest.mark.anyio
async def test_an_instance_whose_earlier_task_failed_is_a_failure_not_run(tmp_path: Path) -> None:
    """A model that never acts fails the earlier task, so the instance would start where it should
    end (already solved): its row is a failure saying why, and the instance itself never runs."""
    config = EvalConfig(
        name="suite-test",
        models=[ModelSpec(model="scripted/refuser")],
        suite=SUITE.name,
        families=["memory"],
        instances=1,
        trials=1,
        memory_iterations=1,
        max_invocations=1,
    )
    rows = await run_eval(config, tmp_path / "r.jsonl")
    inst = find_instance(SUITE.name, config.tasks[0])
    assert [(r.task, r.family, r.true_success) for r in rows] == [(inst.id, "memory", False)]
    assert rows[0].reason.startswith(f"its earlier task {inst.id}-pre1 failed, so it was not run")
    traces = sorted(p.name for p in (tmp_path / "r.traces").rglob("*.jsonl"))
    assert traces == [f"iter-0-{inst.id}-pre1.jsonl"], "the instance itself never ran"
