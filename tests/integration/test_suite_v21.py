"""robocog-v2.1 as data (issue 42): robocog-v1 and robocog-v2 frozen beside it, v2.1 the default, its
splits what their seeds generate, goals that mean what they say and do not hold at the start, more of
it under partial observation, the ungraspable variant in both splits, referring descriptions a
text-only model can resolve from what the tools say, and perturbations set off by the world's state."""

from __future__ import annotations

import functools
import hashlib
from collections import Counter

import pytest

from robocog.agent.families.referring import seen_words
from robocog.agent.suitegen.generator import furnished_room, generate, starts_where_sent, steps_to_find_out
from robocog.agent.symbolic import SceneNames
from robocog.agent.symbolic.plans import solved
from robocog.shared.appearance import attributes
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import DEFAULT_SUITE, SUITES_DIR, Instance, dump_instances, load_split, load_suite

V21 = load_suite("robocog-v2.1")
SPLITS = {split: load_split(V21.name, split) for split in V21.splits}
INSTANCES = [i for split in SPLITS.values() for i in split]

#: robocog-v1's and robocog-v2's files as they were published: their instances never change.
FROZEN_SHA256 = {
    "robocog-v1": {
        "suite.yaml": "d045c9dd1c3329a942f6548467d25e3f6f8d0327f26cfbb644a2c52fd87dc7a2",
        "dev.jsonl": "061327749368c3b182e10a65de03429d8873672f92177ba23848b5af9cdaff08",
        "test.jsonl": "4a3f20e9eccc723757afab6bf215d3f87fafd4982ab9ae19e6257333a1021a91",
    },
    "robocog-v2": {
        "suite.yaml": "043da6e98f980d8fb7fde91784bf953ff8174103dae82508ac78cd3ec9910163",
        "dev.jsonl": "aeb8ace083492dc09876de904398537f2c68a1baf7ecfbc8469e30569d2370a0",
        "test.jsonl": "7f31b2b222c25550d59740f8a797207e2f2d1b80acb350382d361855c536dae9",
    },
}


@functools.cache
def world(name: str) -> SceneNames:
    return SceneNames(load_scene(scene_path(name)))


def where_at_start(instance: Instance) -> dict[str, tuple[str, str] | None]:
    return {o: (s.location, s.position) for o, s in instance.start.items()}


def test_robocog_v1_and_v2_are_frozen_byte_for_byte() -> None:
    for suite, files in FROZEN_SHA256.items():
        for name, digest in files.items():
            assert hashlib.sha256((SUITES_DIR / suite / name).read_bytes()).hexdigest() == digest, (suite, name)


def test_v2_1_is_the_default_suite() -> None:
    from integrations.inspect._suite import SUITE

    assert DEFAULT_SUITE == "robocog-v2.1" == SUITE
    assert load_suite().name == "robocog-v2.1"


def test_v2_1_splits_begin_with_what_their_seeds_generate() -> None:
    for split, instances in SPLITS.items():
        sample = generate(V21, split, per_family=1)
        by_id = {i.id: i for i in instances}
        assert dump_instances(sample) == dump_instances([by_id[i.id] for i in sample])


def test_no_goal_holds_at_the_start_and_no_item_starts_where_it_is_sent() -> None:
    for i in INSTANCES:
        if i.prelude:
            continue  # the task begins where its earlier one ends: the generator checks it there
        w, where = world(i.scene), where_at_start(i)
        assert not solved(i.success, where, where), i.id
        assert not starts_where_sent(w, i.success, where), i.id


def test_the_generator_rejects_an_item_sent_where_it_starts() -> None:
    from robocog.shared.tasks import AtLocation, OnFurniture

    house = world("household")
    where: dict[str, tuple[str, str] | None] = {"mug": ("Kitchen Table", "middle"), "cube": ("Living Room", "floor")}
    assert starts_where_sent(house, [AtLocation(objects=["mug"], location="Kitchen Table")], where)
    shelf = [("Kitchen Shelf", p) for p in ("top", "middle", "bottom")]
    assert not starts_where_sent(
        house, [OnFurniture(objects=["mug"], furniture="Kitchen Shelf", positions=shelf)], where
    )
    assert not starts_where_sent(house, [AtLocation(objects=["cube"], location="Front Door")], where)


def test_a_furnished_rooms_name_says_the_floor_of_it() -> None:
    import re

    for i in INSTANCES:
        w = world(i.scene)
        rooms = [loc.name for loc in w.scene.locations if furnished_room(w, loc.name)]
        for prompt in [i.prompt, *(s.prompt for s in i.prelude)]:
            for room in rooms:
                assert not re.search(rf"(?<!floor of )\bthe {re.escape(room)}(?=[.,]|$)", prompt), (i.id, prompt)


def test_partial_observation_covers_a_third_of_the_suite_over_six_families() -> None:
    partial = [i for i in INSTANCES if i.observe in ("room", "location")]
    assert len(partial) >= 0.3 * len(INSTANCES)
    assert len({i.family for i in partial}) >= 6
    for split, instances in SPLITS.items():
        assert sum(i.observe is not None for i in instances) >= 0.3 * len(instances), split


def test_the_ungraspable_variant_is_in_both_splits_and_optima_of_infeasible_instances_count_finding_out() -> None:
    for split, instances in SPLITS.items():
        assert any(i.variant == "ungraspable" for i in instances), split
    for i in INSTANCES:
        if i.feasible:
            continue
        expected = steps_to_find_out(world(i.scene), where_at_start(i), i.parameters, list(i.perturbations))
        assert i.optimal_steps == expected, i.id
        assert i.optimal_steps == {"ungraspable": i.optimal_steps, "blocked_for_good": 1}.get(i.variant, 0), i.id
        if i.variant == "ungraspable":
            assert i.optimal_steps in (1, 2), i.id


def test_every_referring_description_names_what_the_tools_say_and_fits_one_object_word_by_word() -> None:
    described = [i for i in INSTANCES if i.family == "referring" and "description" in i.parameters]
    assert described
    for i in described:
        w = world(i.scene)
        words = set(i.parameters["description"].split()) - {"the", "thing"}
        item = next(o for o in w.scene.objects if o.name == i.parameters["item"])
        assert words <= set(attributes(item.color, item.size)), i.id  # colour and size: look_around says them
        fits = [name for name, said in seen_words(w).items() if words <= said]
        assert fits == [item.name], i.id


def test_perturbations_are_set_off_by_the_world_and_never_onto_an_occupied_position() -> None:
    recovery = [i for i in INSTANCES if i.family == "recovery"]
    assert {i.variant for i in recovery} == {"slip", "moved", "blocked", "blocked_for_good", "closed"}
    scenes = {i.scene: SceneNames(load_scene(scene_path(i.scene))) for i in recovery}
    for i in recovery:
        (p,) = i.perturbations
        assert p.kind == "slip" or p.when is not None, i.id  # never a count of calls
        world = scenes[i.scene]
        if p.kind == "move_object":
            assert p.to is not None and tuple(p.to) not in {(s.location, s.position) for s in i.start.values()}, i.id
            start, at = world.scene.robot_start, i.start[p.object or ""].location
            assert at != start and world.room_of(at) == world.room_of(start), i.id  # the first look shows it
        if p.kind == "close_container":
            (container,) = [c for c in world.scene.containers if c.name == p.container]
            assert p.when == "leave" and i.start[i.parameters["item"]].location != container.location, i.id
    assert min(Counter(i.variant for i in recovery)[v] for v in ("moved", "closed")) >= 10


@pytest.mark.parametrize("name", ["household", "suite_house", "house-002"])
def test_look_around_words_are_what_the_scene_paints(name: str) -> None:
    w = world(name)
    for o in w.scene.objects:
        colour, size = attributes(o.color, o.size)
        assert colour and size in ("small", "medium", "large")
