"""The suite's seeded generator: the committed splits are what their seeds generate, cover every
family and scene, begin unsolved and are solved by their optimal plans on the server's own verdict,
with which the symbolic verdicts agree."""

from __future__ import annotations

import random

import pytest

from robocog.agent.families import load_families
from robocog.agent.suitegen.generator import derived_seed, generate
from robocog.agent.symbolic import SceneNames, holds, optimal_plan, solved, steps_after
from robocog.server.world.tasks import evaluate
from robocog.shared.results import ObjectPlacement
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import SUITES_DIR, dump_instances, find_instance, load_split, load_suite, select
from robocog.shared.tasks import AtPositions, HonestFailure, TaskSpec

SUITE = load_suite("robocog-v1")
SPLITS = {split: load_split(SUITE.name, split) for split in SUITE.splits}
INSTANCES = [i for split in SPLITS.values() for i in split]


@pytest.fixture(scope="module")
def names() -> dict[str, SceneNames]:
    return {s: SceneNames(load_scene(scene_path(s))) for s in SUITE.scenes}


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
    families = load_families()
    variants = {(f, v.id) for f in SUITE.families for v in families[f].variants}
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
