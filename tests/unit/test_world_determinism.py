"""Determinism and independence: the same seed gives the same world, reset restores the start, two
worlds in one process do not interfere; and a GUI without a display is an error.

Real PyBullet throughout (no mocks); the actions' results and failure messages through the tools,
called with a `RobotSession` as the server calls them. Most tests share one module-scoped `World`
that the `world` fixture (tests/unit/conftest.py) resets before each test.
"""

from __future__ import annotations

import pytest

from robocog.server.tools import move_to
from robocog.server.world.world import World
from robocog.shared.errors import WorldError
from tests.helpers import T1_SEQUENCE, Action
from tests.unit.world_helpers import (
    GRASPABLE,
    RANDOMIZE,
    assert_all_succeeded,
    base_xy,
    layout,
    max_xyz_difference,
    run_sequence,
    session_for,
    xyz,
)

# --- determinism -------------------------------------------------------------------------------


def _scripted_actions(world: World) -> tuple[Action, ...]:
    """Five actions that move an object, whatever the (randomised) layout."""
    cube = world.placement("cube")
    free_shelf = next(
        pos for pos in ("top", "middle", "bottom") if ("Kitchen Shelf", pos) not in set(layout(world).values())
    )
    return (
        ("move_to", str(cube.location)),
        ("grab", "cube"),
        ("move_to", "Kitchen Shelf"),
        ("place", "Kitchen Shelf", free_shelf),
        ("move_to", "Living Room"),
    )


def test_same_seed_gives_identical_worlds_at_start() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=7, options=RANDOMIZE) as b:
        assert layout(a) == layout(b)
        assert max_xyz_difference(xyz(a), xyz(b)) <= 1e-9


def test_same_seed_gives_identical_worlds_after_the_same_actions() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=7, options=RANDOMIZE) as b:
        actions = _scripted_actions(a)
        results_a = [r.model_dump() for r in run_sequence(session_for(a), actions)]
        results_b = [r.model_dump() for r in run_sequence(session_for(b), actions)]
        assert results_a == results_b
        assert all(r["status"] == "success" for r in results_a), results_a
        assert a.steps == b.steps
        assert max_xyz_difference(xyz(a), xyz(b)) <= 1e-9


def test_different_seeds_give_different_layouts() -> None:
    with World(seed=7, options=RANDOMIZE) as a, World(seed=8, options=RANDOMIZE) as b:
        assert layout(a) != layout(b)


def test_randomized_layout_puts_each_item_resting_on_its_own_position() -> None:
    with World(seed=3, options=RANDOMIZE) as w:
        placements = w.placements()
        for name in GRASPABLE:
            assert placements[name].state == "on_position", placements[name]
            assert placements[name].resting
        assert len({layout(w)[name] for name in GRASPABLE}) == len(GRASPABLE)
        assert w.robot_location() == "Front Door"


def test_reset_with_the_same_seed_twice_gives_the_same_layout() -> None:
    with World() as w:
        w.reset(seed=11, options=RANDOMIZE)
        first, first_steps = xyz(w), w.steps
        w.reset(seed=11, options=RANDOMIZE)
        assert max_xyz_difference(first, xyz(w)) <= 1e-9
        assert w.steps == first_steps


def test_reset_without_a_seed_continues_the_worlds_generator() -> None:
    with World(seed=7) as a, World(seed=7) as b:
        a.reset(options=RANDOMIZE)
        b.reset(options=RANDOMIZE)
        first = layout(a)
        assert first == layout(b)  # the same generator state: the same draw
        a.reset(options=RANDOMIZE)
        b.reset(seed=7, options=RANDOMIZE)
        assert layout(b) == first  # reseeded: the first draw again
        assert a.seed == b.seed == 7


def test_reset_restores_static_setup_after_moves(world: World) -> None:
    reference = xyz(world)
    robot = session_for(world)
    assert robot.call(move_to.TOOL, location="Kitchen Table").status == "success"
    world.reset(seed=5, options=RANDOMIZE)
    robot.call(move_to.TOOL, location="Living Room")
    world.reset()
    assert world.robot_location() == "Front Door"
    assert base_xy(world) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert world.steps == 0
    assert max_xyz_difference(reference, xyz(world)) <= 1e-6


def test_reset_restores_static_setup_after_the_t1_sequence() -> None:
    with World() as fresh, World() as w:
        assert_all_succeeded(run_sequence(session_for(w), T1_SEQUENCE), T1_SEQUENCE)
        w.reset()
        assert w.holding is None
        assert w.robot_location() == "Front Door"
        assert w.steps == 0
        assert layout(w) == layout(fresh)
        assert max_xyz_difference(xyz(fresh), xyz(w)) <= 1e-6


def test_reset_with_a_seed_after_an_episode_matches_a_fresh_world_with_that_seed() -> None:
    with World(seed=7, options=RANDOMIZE) as fresh, World() as used:
        assert_all_succeeded(run_sequence(session_for(used), T1_SEQUENCE), T1_SEQUENCE)
        used.reset(seed=7, options=RANDOMIZE)
        assert layout(used) == layout(fresh)
        assert max_xyz_difference(xyz(fresh), xyz(used)) <= 1e-9


def test_reset_with_the_same_seed_twice_after_earlier_resets_gives_the_same_layout() -> None:
    with World() as w:
        robot = session_for(w)
        assert robot.call(move_to.TOOL, location="Kitchen Table").status == "success"
        w.reset(seed=5, options=RANDOMIZE)
        assert robot.call(move_to.TOOL, location="Living Room").status == "success"
        w.reset()
        w.reset(seed=11, options=RANDOMIZE)
        first = xyz(w)
        w.reset(seed=11, options=RANDOMIZE)
        assert max_xyz_difference(first, xyz(w)) <= 1e-9


def test_reset_takes_keywords_and_names_an_unknown_option(world: World) -> None:
    with pytest.raises(TypeError):
        world.reset(5)  # type: ignore[call-arg]
    with pytest.raises(WorldError, match="shuffle"):
        world.reset(options={"shuffle": True})
    with pytest.raises(WorldError, match="randomize"):
        world.reset(options={"randomize": "yes"})
    with pytest.raises(WorldError, match="shuffle"):
        World(options={"shuffle": True})
    assert world.reset(options={"randomize": False}).robot.location == "Front Door"


# --- independence ------------------------------------------------------------------------------


def test_two_worlds_in_one_process_do_not_interfere() -> None:
    with World() as a, World() as b:
        before_b, steps_b = xyz(b), b.steps
        actions: tuple[Action, ...] = (
            ("grab", "cube"),
            ("move_to", "Kitchen Shelf"),
            ("place", "Kitchen Shelf", "top"),
        )
        assert_all_succeeded(run_sequence(session_for(a), actions), actions)
        assert b.steps == steps_b
        assert xyz(b) == before_b
        assert b.robot_location() == "Front Door"
        assert b.holding is None
        # And the other way round.
        before_a, steps_a = xyz(a), a.steps
        assert session_for(b).call(move_to.TOOL, location="Living Room").status == "success"
        assert a.steps == steps_a
        assert xyz(a) == before_a


# --- construction ------------------------------------------------------------------------------


def test_gui_without_a_display_raises_world_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(WorldError, match="display"):
        World(gui=True)
