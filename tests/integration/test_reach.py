"""The physics survey of positions the arm cannot reach (`robocog.server.world.reach`): the committed
file is what the survey finds (on a sample of scenes: the whole survey takes a minute), a hand-made
scene has none, and the suite generator never poses a task on one."""

from __future__ import annotations

import json

import pytest

from robocog.agent.symbolic.world import REACH_FILE, SceneNames, unreachable
from robocog.server.world.reach import survey
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import load_split

COMMITTED = json.loads(REACH_FILE.read_text(encoding="utf-8"))


@pytest.mark.parametrize("scene", ["household", "house-049", "house-035"])
def test_the_committed_survey_is_what_physics_finds(scene: str) -> None:
    assert survey([scene]) == {scene: COMMITTED[scene]}


def test_the_hand_made_scenes_are_reachable_everywhere_and_some_generated_houses_are_not() -> None:
    assert not any(COMMITTED[s] for s in ("household", "suite_house", "flat", "kitchen_plus"))
    assert ["Kitchen Shelf", "top"] in COMMITTED["house-049"]  # too high for the bottle


def test_no_robocog_v2_instance_starts_or_ends_on_a_position_out_of_reach() -> None:
    spots = {name: set(SceneNames(load_scene(scene_path(name))).spots) for name in COMMITTED if COMMITTED[name]}
    for name, free in spots.items():
        assert not unreachable(name) & free, name  # nor parks there: the generator's world leaves them out
    for split in ("dev", "test"):
        for instance in load_split("robocog-v2", split):
            out = unreachable(instance.scene)
            assert not out & {(s.location, s.position) for s in instance.start.values()}, instance.id
            targets = instance.parameters.get("targets") or []
            assert not out & {(loc, pos) for _, loc, pos in targets}, instance.id
