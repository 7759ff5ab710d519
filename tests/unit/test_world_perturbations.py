"""Perturbations from physics: a grasp that slips mid-drive leaves the object where it lands, a blocked
corridor stops move_to (and lets it through once the block lifts), an object moved behind the robot's
back is where look_around says, a container closed behind its back hides its contents; announced or
silent; the same seed makes the same world.

Real PyBullet throughout, the tools run through a session as the server runs them.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.world.world import World
from robocog.shared.errors import WorldError
from robocog.shared.perturbations import Perturbation
from robocog.shared.results import LookAroundResult, MoveResult
from robocog.shared.scene import Scene
from tests.unit.world_helpers import TOOLS, perform, session_for

SLIP = Perturbation(kind="slip", announce=True)
BLOCK = Perturbation(kind="block_edge", edge=("Hallway Area Door", "Kitchen Door"), duration=3)


def carry_cube_to_the_kitchen(world: World, seed: int) -> tuple[RobotSession, MoveResult]:
    world.reset(seed=seed, perturbations=[SLIP])
    robot = session_for(world)
    assert perform(robot, ("grab", "cube")).status == "success"
    moved = perform(robot, ("move_to", "Kitchen Area Left"))
    assert isinstance(moved, MoveResult)
    return robot, moved


def to_segment(p: tuple[float, ...], a: tuple[float, float], b: tuple[float, float]) -> float:
    """The distance from point `p` to the segment a-b."""
    (ax, ay), (bx, by), (px, py) = a, b, p[:2]
    length2 = (bx - ax) ** 2 + (by - ay) ** 2
    f = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - ax) * (bx - ax) + (py - ay) * (by - ay)) / length2))
    return math.dist((px, py), (ax + f * (bx - ax), ay + f * (by - ay)))


def test_a_slip_leaves_the_object_where_it_lands_and_ground_truth_says_so(world: World) -> None:
    start = world.placement("cube")
    robot, moved = carry_cube_to_the_kitchen(world, seed=4)
    assert moved.status == "success" and moved.location == "Kitchen Area Left"  # the drive itself went on
    cube = world.placement("cube")
    assert world.holding is None and cube.state != "held"
    assert cube.resting and cube.xyz[2] < 0.1  # on the floor, at rest
    assert math.dist(cube.xyz[:2], start.xyz[:2]) > 0.3  # not where it was grabbed
    # near the way driven (it left the hand at 3 m/s and slid on): Front Door -> ... -> Kitchen Area Left
    way = [world.map.points[n] for n in moved.path]
    assert min(to_segment(cube.xyz[:2], a, b) for a, b in itertools.pairwise(way)) < 2.0
    # and near a location of the way, where the robot can stand to grab it again
    assert min(math.dist(cube.xyz[:2], p) for p in way) < 1.5
    assert cube.location in moved.path
    [event] = world.perturbation_events
    assert (event.kind, event.object, event.call, event.announced) == ("slip", "cube", 2, True)
    assert event.xyz == pytest.approx(cube.xyz, abs=1e-3)
    assert "Something changed: The cube slipped out of the hand" in moved.message
    assert robot.perturbations == [event]
    assert "cube" not in [o for o in world.state().objects if o.state == "held"]


def test_a_slip_happens_only_with_an_object_in_hand(world: World) -> None:
    world.reset(perturbations=[SLIP])
    robot = session_for(world)
    perform(robot, ("move_to", "Kitchen Area Left"))
    assert world.perturbation_events == []


def test_a_drive_blocked_at_once_keeps_the_slip_for_the_next_drive(world: World) -> None:
    world.reset(perturbations=[SLIP, Perturbation(kind="block_edge", edge=("Front Door", "Hallway Area Door"))])
    robot = session_for(world)
    assert perform(robot, ("grab", "cube")).status == "success"  # call 1: the way out is blocked from now
    assert perform(robot, ("move_to", "Kitchen Area Left")).status == "failure"  # call 2: no drive at all
    assert world.holding == "cube"
    perform(robot, ("look_around",))  # call 3
    moved = perform(robot, ("move_to", "Kitchen Area Left"))  # call 4: the block lifted; the first loaded drive
    assert moved.status == "success" and world.holding is None
    assert [e.kind for e in world.perturbation_events] == ["block_edge", "block_edge", "slip"]


def test_the_same_seed_makes_the_same_slip(world: World) -> None:
    carry_cube_to_the_kitchen(world, seed=11)
    first = world.placement("cube").xyz
    carry_cube_to_the_kitchen(world, seed=11)
    assert world.placement("cube").xyz == pytest.approx(first, abs=1e-6)


def test_a_blocked_corridor_stops_move_to_and_frees_again_afterwards(world: World) -> None:
    world.reset(perturbations=[BLOCK])
    robot = session_for(world)
    blocked = perform(robot, ("move_to", "Kitchen Table"))  # call 1: the block begins, for 3 calls
    assert isinstance(blocked, MoveResult)
    assert (blocked.status, blocked.error, blocked.location) == ("failure", "no_path", "Hallway Area Door")
    assert blocked.path == ["Front Door", "Hallway Area Door"]
    assert "blocked" in blocked.message and "stopped at Hallway Area Door" in blocked.message
    assert world.robot_location() == "Hallway Area Door"
    again = perform(robot, ("move_to", "Kitchen Table"))  # call 2: still blocked
    assert isinstance(again, MoveResult) and again.status == "failure" and again.location == "Hallway Area Door"
    assert perform(robot, ("move_to", "Living Room")).status == "success"  # call 3: other ways are open
    freed = perform(robot, ("move_to", "Kitchen Table"))  # call 4: the block has lifted
    assert freed.status == "success" and world.robot_location() == "Kitchen Table"
    assert [(e.kind, e.call, e.ended) for e in world.perturbation_events] == [
        ("block_edge", 1, False),
        ("block_edge", 4, True),
    ]
    assert "Something changed" not in blocked.message  # silent: only the failure tells


def test_calls_count_from_the_reset_so_a_later_episode_in_the_same_world_goes_on_counting(world: World) -> None:
    world.reset(perturbations=[BLOCK])
    robot = session_for(world)
    assert perform(robot, ("move_to", "Kitchen Table")).status == "failure"  # call 1: blocked for 3 calls
    robot.begin_task("T2")  # a new episode in the same world: its calls count from 1 again
    assert perform(robot, ("move_to", "Kitchen Table")).status == "failure"  # 2nd call since the reset
    perform(robot, ("look_around",))
    assert perform(robot, ("move_to", "Kitchen Table")).status == "success"  # 4th: the block lifted
    assert [(e.call, e.ended) for e in world.perturbation_events] == [(1, False), (3, True)]  # the episode's calls


def test_an_object_moved_behind_the_robots_back_is_found_where_it_now_is(world: World) -> None:
    moved = Perturbation(kind="move_object", object="mug", to=("Hallway Area Door", "floor"), at_call=2, announce=True)
    world.reset(perturbations=[moved])
    robot = session_for(world)
    perform(robot, ("move_to", "Kitchen Table"))  # call 1: nothing due
    look = perform(robot, ("look_around",))  # call 2: due, but the robot stands by the mug: it waits
    assert world.perturbation_events == [] and "Something changed" not in look.message
    perform(robot, ("move_to", "Kitchen Area Left"))  # call 3: the robot is elsewhere now
    mug = world.placement("mug")
    assert (mug.state, mug.location, mug.position) == ("on_position", "Hallway Area Door", "floor")
    look = perform(robot, ("look_around",))
    assert isinstance(look, LookAroundResult)
    hall = next(v for v in look.locations if v.name == "Hallway Area Door")
    assert "mug" in hall.objects
    assert not any("mug" in v.objects for v in look.locations if v.name == "Kitchen Table")
    [event] = world.perturbation_events
    assert (event.kind, event.object, event.call) == ("move_object", "mug", 3)


def test_a_moved_object_without_a_target_goes_to_a_seeded_free_floor_spot(world: World) -> None:
    moved = Perturbation(kind="move_object", object="box")
    spots = []
    for _ in range(2):
        world.reset(seed=5, perturbations=[moved])
        perform(session_for(world), ("look_around",))
        box = world.placement("box")
        assert box.state == "on_position" and box.position == "floor" and box.location != "Living Room"
        spots.append(box.location)
    assert spots[0] == spots[1]


def test_no_perturbation_leaves_the_paper_world_as_it_was(world: World) -> None:
    assert world.scene.perturbations == []
    robot = session_for(world)
    perform(robot, ("grab", "cube"))
    perform(robot, ("move_to", "Kitchen Shelf"))
    assert world.holding == "cube" and world.perturbation_events == []


def test_a_perturbation_naming_what_the_scene_lacks_is_refused(world: World) -> None:
    with pytest.raises(WorldError, match="'piano' is not a graspable object"):
        world.reset(perturbations=[Perturbation(kind="move_object", object="piano")])
    with pytest.raises(WorldError, match="Front Door - Kitchen Table is not an edge"):
        world.reset(perturbations=[Perturbation(kind="block_edge", edge=("Front Door", "Kitchen Table"))])
    with pytest.raises(ValueError, match="needs `container`"):
        Perturbation(kind="close_container")


# --- a container someone closes (kitchen_plus) -----------------------------------------------------


@pytest.fixture(scope="module")
def kitchen() -> Iterator[World]:
    with World("kitchen_plus") as w:
        yield w


def test_a_container_closed_behind_the_robots_back_hides_its_contents(kitchen: World) -> None:
    closing = Perturbation(kind="close_container", container="kitchen_drawer", at_call=3, announce=True)
    kitchen.reset(perturbations=[closing])
    robot = session_for(kitchen)
    assert perform(robot, ("move_to", "Kitchen Drawer")).status == "success"  # call 1
    assert robot.call(TOOLS["open"], furniture="kitchen_drawer").outcome == "opened"  # call 2
    assert perform(robot, ("look_around",)).status == "success"  # call 3: due, the robot is there: it waits
    assert kitchen.furniture("kitchen_drawer").state == "open"
    away = perform(robot, ("move_to", "Kitchen Area Left"))  # call 4: someone closes it
    assert "Something changed: Someone closed the kitchen drawer." in away.message
    drawer = kitchen.furniture("kitchen_drawer")
    assert (drawer.state, drawer.contents) == ("closed", ["sponge"])
    look = perform(robot, ("look_around",))
    assert isinstance(look, LookAroundResult)
    assert not any("sponge" in v.objects for v in look.locations)
    [event] = kitchen.perturbation_events
    assert (event.kind, event.container, event.call) == ("close_container", "kitchen_drawer", 4)


def test_a_container_the_robot_opened_is_closed_behind_it_on_its_first_drive_away(kitchen: World) -> None:
    leaving = Perturbation(kind="close_container", container="kitchen_drawer", when="leave", announce=True)
    kitchen.reset(perturbations=[leaving])
    robot = session_for(kitchen)
    assert perform(robot, ("move_to", "Kitchen Drawer")).status == "success"  # drives to it: nothing yet
    assert perform(robot, ("look_around",)).status == "success"
    assert robot.call(TOOLS["open"], furniture="kitchen_drawer").outcome == "opened"
    assert perform(robot, ("look_around",)).status == "success"  # however many calls, while it stays
    assert kitchen.furniture("kitchen_drawer").state == "open"
    away = perform(robot, ("move_to", "Kitchen Area Left"))  # it leaves: someone shuts it behind it
    assert "Something changed: Someone closed the kitchen drawer." in away.message
    assert kitchen.furniture("kitchen_drawer").state == "closed"
    [event] = kitchen.perturbation_events
    assert (event.kind, event.container) == ("close_container", "kitchen_drawer")
    perform(robot, ("move_to", "Kitchen Drawer"))
    assert robot.call(TOOLS["open"], furniture="kitchen_drawer").outcome == "opened"
    perform(robot, ("move_to", "Kitchen Area Left"))  # it happens once
    assert kitchen.furniture("kitchen_drawer").state == "open"


def test_leave_waits_for_the_robot_to_open_the_container(kitchen: World) -> None:
    leaving = Perturbation(kind="close_container", container="kitchen_drawer", when="leave")
    kitchen.reset(perturbations=[leaving])
    robot = session_for(kitchen)
    perform(robot, ("move_to", "Kitchen Drawer"))
    perform(robot, ("move_to", "Kitchen Area Left"))  # it leaves a drawer it never opened
    assert kitchen.perturbation_events == []
    assert kitchen.perturber.pending == [leaving]


# --- declared in a scene ---------------------------------------------------------------------------


def test_a_scene_declares_perturbations_for_every_episode_and_reset_may_replace_them(world: World) -> None:
    data = world.scene.model_dump()
    data["perturbations"] = [{"kind": "block_edge", "edge": ["Front Door", "Hallway Area Door"], "duration": 1}]
    with World(Scene.model_validate(data)) as blocked:
        robot = session_for(blocked)
        assert perform(robot, ("move_to", "Kitchen Table")).status == "failure"  # the scene's own
        blocked.reset()
        assert perform(session_for(blocked), ("move_to", "Hallway Area Door")).status == "failure"  # every episode
        blocked.reset(perturbations=[])
        assert perform(session_for(blocked), ("move_to", "Hallway Area Door")).status == "success"
    data["perturbations"] = [{"kind": "close_container", "container": "fridge"}]
    with pytest.raises(ValueError, match="'fridge' is not a container"):
        Scene.model_validate(data)


def test_a_suite_instance_takes_perturbations_too(world: World) -> None:
    robot = session_for(world)
    robot.begin_instance("robocog-v1", "dev-put_away-000", [BLOCK])
    assert robot.world.perturber.pending == [BLOCK]
    with pytest.raises(ValueError, match="not an edge"):
        robot.begin_instance("robocog-v1", "dev-put_away-000", [Perturbation(kind="block_edge", edge=("a", "b"))])
