"""The world's state from its physics: the start state, ground truth, the physical primitives, the
paper's tasks judged, and invariants under random action sequences.

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

import math
import random
from collections import Counter

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.world.tasks import evaluate, task_catalogue
from robocog.server.world.world import World
from robocog.shared.results import ObjectPlacement
from tests.helpers import PAPER_LOCATIONS, PAPER_POSITIONS, T1_SEQUENCE, T2_SEQUENCE, Action
from tests.unit.world_helpers import GRASPABLE, assert_all_succeeded, base_xy, perform, run_sequence

# --- start state -------------------------------------------------------------------------------


def test_start_state_objects_rest_where_the_paper_puts_them(world: World) -> None:
    p = world.placements()
    assert (p["cube"].state, p["cube"].location, p["cube"].position) == ("on_position", "Front Door", "floor")
    assert (p["box"].state, p["box"].location, p["box"].position) == ("on_position", "Living Room", "floor")
    assert (p["mug"].state, p["mug"].location, p["mug"].position) == ("on_position", "Kitchen Table", "middle")
    for name in GRASPABLE:
        assert p[name].resting, name


def test_start_state_tv_is_loose_near_living_room_tv(world: World) -> None:
    tv = world.placement("tv")
    assert tv.state == "loose"
    assert tv.location == "Living Room TV"
    assert tv.resting  # on its table, not falling
    assert math.hypot(tv.xyz[0] - 8.0, tv.xyz[1] + 4.5) < 1.3
    assert not world.object_spec("tv").graspable


def test_start_state_robot_at_front_door_holding_nothing(world: World) -> None:
    assert world.robot_location() == "Front Door"
    assert world.holding is None
    assert base_xy(world) == pytest.approx((0.0, 0.0), abs=1e-6)
    state = world.state()
    assert state.robot.location == "Front Door"
    assert state.robot.holding is None
    assert state.steps == world.steps == 0


# --- ground truth ------------------------------------------------------------------------------


def test_names_come_in_scene_order(world: World) -> None:
    assert world.object_names == [o.name for o in world.scene.objects]
    assert world.position_names("Kitchen Shelf") == ["top", "middle", "bottom"]
    assert world.position_names("Kitchen Door") == []
    assert world.object_spec("mug").name == "mug"


def test_occupants_and_the_state_agree_with_the_placements(world: World) -> None:
    assert world.occupant("Front Door", "floor") == "cube"
    assert world.occupant("Front Door", "floor", ignore="cube") is None
    assert world.occupant("Kitchen Shelf", "top") is None
    state = world.state()
    assert [p.object for p in state.objects] == world.object_names
    taken = {(p.location, p.position): p.occupied_by for p in state.positions if p.occupied_by}
    assert taken == {
        ("Front Door", "floor"): "cube",
        ("Living Room", "floor"): "box",
        ("Kitchen Table", "middle"): "mug",
    }
    assert {(p.location, p.position) for p in state.positions} == {
        (loc, pos) for loc, names in PAPER_POSITIONS.items() for pos in names
    }


def test_the_held_object_occupies_no_position(world: World) -> None:
    assert world.pick("cube").ok
    assert world.holding == "cube"
    assert world.placement("cube").state == "held"
    assert world.placement("cube").location == "Front Door"
    assert world.occupant("Front Door", "floor") is None
    assert world.state().robot.holding == "cube"


# --- the physical primitives -------------------------------------------------------------------


def test_drive_follows_the_given_path_and_reports_each_segment(world: World) -> None:
    calls: list[tuple[float, float, str]] = []
    driven = world.drive(["Front Door", "Hallway Area Door"], lambda *c: calls.append(c))
    assert driven == pytest.approx(3.0)
    assert calls == [(1, 1, "reached Hallway Area Door")]
    assert world.robot_location() == "Hallway Area Door"
    assert base_xy(world) == pytest.approx(PAPER_LOCATIONS["Hallway Area Door"], abs=1e-6)
    assert world.steps > 0


def test_pick_out_of_the_arms_reach_moves_nothing(world: World) -> None:
    reach = world.pick("mug")  # on the kitchen table, metres away
    assert (reach.ok, reach.failure) == (False, "unreachable")
    assert reach.gap_m > world.robot_spec.grasp_threshold
    assert world.holding is None
    assert world.steps == 0


def test_put_down_reports_where_the_object_came_to_rest(world: World) -> None:
    assert world.pick("cube").ok
    far = world.put_down("Kitchen Shelf", "top")
    assert (far.ok, far.failure) == (False, "unreachable")
    assert world.holding == "cube"
    reach = world.put_down("Front Door", "floor")
    assert reach.ok and reach.failure is None
    assert reach.placement is not None
    assert (reach.placement.state, reach.placement.location, reach.placement.position) == (
        "on_position",
        "Front Door",
        "floor",
    )
    assert world.holding is None


# --- the paper's tasks -------------------------------------------------------------------------


def test_t1_is_false_at_the_start(world: World) -> None:
    verdict = evaluate(task_catalogue()["T1"], world.placements())
    assert not verdict.success


def test_t2_is_false_at_the_start(world: World) -> None:
    start = world.placements()
    assert not evaluate(task_catalogue()["T2"], start, start).success


def test_t1_sequence_satisfies_t1(world: World, robot: RobotSession) -> None:
    assert_all_succeeded(run_sequence(robot, T1_SEQUENCE), T1_SEQUENCE)
    verdict = evaluate(task_catalogue()["T1"], world.placements())
    assert verdict.success, verdict.reason
    assert {name: world.placement(name).position for name in GRASPABLE} == {
        "cube": "top",
        "box": "middle",
        "mug": "bottom",
    }


def test_t2_sequence_after_t1_satisfies_t2(world: World, robot: RobotSession) -> None:
    t2 = task_catalogue()["T2"]
    assert_all_succeeded(run_sequence(robot, T1_SEQUENCE), T1_SEQUENCE)
    baseline = world.placements()
    assert not evaluate(t2, world.placements(), baseline).success  # nothing swapped yet
    assert_all_succeeded(run_sequence(robot, T2_SEQUENCE), T2_SEQUENCE)
    verdict = evaluate(t2, world.placements(), baseline)
    assert verdict.success, verdict.reason
    assert world.placement("mug").position == baseline["cube"].position
    assert world.placement("cube").position == baseline["mug"].position


# --- invariants under random action sequences --------------------------------------------------

_LOCATIONS = list(PAPER_LOCATIONS)
_BAD_LOCATIONS = ["Garage", "Kitchen Shelve", "kitchen shelf"]
_OBJECTS = ["cube", "box", "mug", "tv"]
_BAD_OBJECTS = ["banana", "cub"]
_POSITIONS = ["top", "middle", "bottom", "floor", "ceiling"]


def _random_action(rng: random.Random, world: World) -> Action:
    """A random action over valid and invalid names, biased towards ones that can succeed."""
    here = world.robot_location()
    loose = {n: p for n, p in world.placements().items() if p.state != "held"}
    kind = rng.choice(["look_around", "move_to", "move_to", "grab", "grab", "place", "place"])
    if kind == "place" and world.holding is None and rng.random() < 0.7:
        kind = "grab"
    elif kind == "grab" and world.holding is not None and rng.random() < 0.7:
        kind = "place"
    if kind == "look_around":
        return ("look_around",)
    if kind == "move_to":
        if rng.random() < 0.15:
            return ("move_to", rng.choice(_BAD_LOCATIONS))
        targets = [p.location for p in loose.values() if p.location] + _LOCATIONS
        return ("move_to", rng.choice(targets))
    if kind == "grab":
        if rng.random() < 0.15:
            return ("grab", rng.choice(_BAD_OBJECTS))
        near = [n for n, p in loose.items() if p.location == here]
        return ("grab", rng.choice(near if near and rng.random() < 0.7 else _OBJECTS))
    location = here if rng.random() < 0.8 else rng.choice(_LOCATIONS + _BAD_LOCATIONS)
    own = sorted(PAPER_POSITIONS.get(location, set()))
    return ("place", location, rng.choice(own if own and rng.random() < 0.7 else _POSITIONS))


def _check_invariants(world: World, context: str) -> None:
    placements: dict[str, ObjectPlacement] = world.placements()
    assert set(placements) == {o.name for o in world.scene.objects}, context
    for name, p in placements.items():
        assert all(math.isfinite(v) for v in p.xyz), (context, name, p.xyz)
        assert p.xyz[2] > -0.05, (context, name, p.xyz)
    taken = Counter((p.location, p.position) for p in placements.values() if p.state == "on_position")
    assert all(n == 1 for n in taken.values()), (context, taken)
    held = [name for name, p in placements.items() if p.state == "held"]
    assert held == ([world.holding] if world.holding else []), (context, held, world.holding)
    if world.holding:
        x, y, _ = placements[world.holding].xyz
        bx, by = base_xy(world)
        assert math.hypot(x - bx, y - by) < 0.6, (context, world.holding, (x, y), (bx, by))


@pytest.mark.parametrize("seed", [10, 11, 14])
def test_invariants_hold_after_every_action_of_a_random_sequence(world: World, robot: RobotSession, seed: int) -> None:
    rng = random.Random(seed)
    outcomes: Counter[tuple[str, str]] = Counter()
    for i in range(15):
        action = _random_action(rng, world)
        result = perform(robot, action)
        outcomes[(action[0], result.status)] += 1
        _check_invariants(world, f"seed {seed}, action {i}: {action} -> {result.status} {result.error}")
    # The sequence did exercise the physics (not only failures).
    assert outcomes[("grab", "success")] >= 1 and outcomes[("place", "success")] >= 1, outcomes
