"""Furniture that opens, from physics: kitchen_plus's drawer, cabinet and fridge built from their
dimensions, ground truth of what is inside from the joint and the poses, open and close through the
tools (what physics did: opened, closed, blocked), and what a closed container hides from look_around,
grab and place.

Real PyBullet throughout; one `World("kitchen_plus")` for the module, reset before each test.
"""

from __future__ import annotations

from collections.abc import Iterator

import pybullet
import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.world.world import World
from robocog.shared.results import GrabResult, LookAroundResult, OpenCloseResult, PlaceResult
from tests.unit.world_helpers import TOOLS, perform


@pytest.fixture(scope="module")
def shared_world() -> Iterator[World]:
    with World("kitchen_plus") as w:
        yield w


def go(robot: RobotSession, location: str) -> None:
    assert perform(robot, ("move_to", location)).status == "success"


def operate(robot: RobotSession, verb: str, furniture: str) -> OpenCloseResult:
    result = robot.call(TOOLS[verb], furniture=furniture)
    assert isinstance(result, OpenCloseResult)
    return result


# --- the start state -------------------------------------------------------------------------------


def test_containers_start_closed_with_their_contents_inside(world: World) -> None:
    state = world.state()
    assert [(f.name, f.kind, f.state, f.contents) for f in state.furniture] == [
        ("kitchen_drawer", "drawer", "closed", ["sponge"]),
        ("kitchen_cabinet", "cabinet", "closed", []),
        ("fridge", "fridge", "closed", ["bottle"]),
    ]
    sponge, bottle = world.placement("sponge"), world.placement("bottle")
    assert (sponge.state, sponge.location, sponge.position, sponge.inside) == (
        "on_position",
        "Kitchen Drawer",
        "inside",
        "kitchen_drawer",
    )
    assert (bottle.state, bottle.inside) == ("on_position", "fridge")
    assert world.placement("mug").inside is None


def test_a_world_without_containers_reads_as_before() -> None:
    """The paper's household: no `furniture` in the state, no `inside` on a placement (the wire is unchanged)."""
    with World() as paper:
        dumped = paper.state().model_dump(mode="json")
    assert "furniture" not in dumped
    assert all("inside" not in p for p in dumped["objects"])


# --- open and close, from physics ------------------------------------------------------------------


def test_a_drawer_opened_then_closed_keeps_what_is_inside(robot: RobotSession, world: World) -> None:
    start = world.placement("sponge").xyz
    go(robot, "Kitchen Drawer")
    opened = operate(robot, "open", "kitchen_drawer")
    assert (opened.status, opened.outcome, opened.state, opened.opening) == ("success", "opened", "open", 1.0)
    assert "sponge" in opened.message and opened.steps > 0
    out = world.placement("sponge")
    assert out.inside == "kitchen_drawer" and out.position == "inside"
    assert start[1] - out.xyz[1] == pytest.approx(0.36, abs=0.02)  # it slid out (-y) with the drawer
    closed = operate(robot, "close", "kitchen_drawer")
    assert (closed.status, closed.outcome, closed.state) == ("success", "closed", "closed")
    back = world.placement("sponge")
    assert (back.state, back.inside, back.position) == ("on_position", "kitchen_drawer", "inside")
    assert back.xyz[1] == pytest.approx(start[1], abs=0.02)
    assert world.furniture("kitchen_drawer").contents == ["sponge"]


def test_a_door_swings_out_over_its_sweep_and_back(robot: RobotSession, world: World) -> None:
    go(robot, "Fridge")
    box = world.sim.containers["fridge"]
    closed_aabb = world.client.getAABB(box.body, 0)
    assert operate(robot, "open", "fridge").outcome == "opened"
    lo, _ = world.client.getAABB(box.body, 0)
    front = box.geometry.footprint()[1]  # the fridge faces -y: its front is its low y
    assert lo[1] < front - 0.5, "the open door stands out in front of the fridge"
    assert operate(robot, "close", "fridge").outcome == "closed"
    assert world.client.getAABB(box.body, 0)[0][1] == pytest.approx(closed_aabb[0][1], abs=0.01)


def test_a_door_held_by_a_fixed_object_in_its_way_reports_blocked(robot: RobotSession, world: World) -> None:
    go(robot, "Kitchen Cabinet")
    mug = world.sim.objects["mug"]
    z = mug.bottom + 0.002
    world.sim.put(mug, 3.7, 5.3, z, 0.0)  # in the door's swing, then welded to the floor there
    weld = world.client.createConstraint(
        mug.body, -1, world.sim.floor, -1, pybullet.JOINT_FIXED, [0, 0, 0], [0, 0, 0], [3.7, 5.3, z]
    )
    try:
        result = operate(robot, "open", "kitchen_cabinet")
        assert (result.status, result.error, result.outcome, result.state) == ("failure", "blocked", "blocked", "open")
        assert result.opening is not None and 0.0 < result.opening < 0.9
        assert "mug" in result.message and "in the way" in result.message
        held_at = world.furniture("kitchen_cabinet").opening
        for _ in range(120):
            world.sim.step()
        assert world.furniture("kitchen_cabinet").opening == pytest.approx(held_at, abs=0.02), "the motor holds it"
    finally:
        world.client.removeConstraint(weld)


def test_a_light_object_in_the_way_is_pushed_aside(robot: RobotSession, world: World) -> None:
    cube = world.sim.objects["cube"]
    world.sim.put(cube, 3.7, 5.3, cube.bottom + 0.002, 0.0)  # where the cabinet's door swings, not fixed
    world.sim.settle()
    go(robot, "Kitchen Cabinet")
    result = operate(robot, "open", "kitchen_cabinet")
    assert (result.outcome, result.opening) == ("opened", 1.0)
    x, y, _ = world.placement("cube").xyz
    assert (x - 3.7) ** 2 + (y - 5.3) ** 2 > 0.1**2, "the door moved it"


def test_the_same_actions_give_the_same_world() -> None:
    """Containers keep a seeded world deterministic: two worlds, the same opens, close and grab."""

    def episode() -> dict[str, tuple[float, ...]]:
        from tests.unit.world_helpers import session_for

        with World("kitchen_plus", seed=3) as w:
            robot = session_for(w)
            go(robot, "Kitchen Drawer")
            for verb in ("open", "close", "open"):
                assert operate(robot, verb, "kitchen_drawer").status == "success"
            assert perform(robot, ("grab", "sponge")).status == "success"
            return {name: (*p.xyz, w.sim.joint("kitchen_drawer")) for name, p in w.placements().items()}

    assert episode() == episode()


def test_open_and_close_failures_are_reported(robot: RobotSession, world: World) -> None:
    away = operate(robot, "open", "fridge")
    assert (away.error, away.status) == ("not_at_location", "failure") and "move_to('Fridge')" in away.message
    unknown = operate(robot, "open", "fridge door")
    assert unknown.error == "unknown_furniture" and unknown.suggestions == ["fridge"]
    shelf = operate(robot, "open", "kitchen shelf")
    assert shelf.error == "not_openable" and "kitchen_drawer" in shelf.message
    go(robot, "Kitchen Drawer")
    assert operate(robot, "close", "kitchen drawer").outcome == "already_closed"
    assert operate(robot, "open", "the kitchen drawer").outcome == "opened"
    again = operate(robot, "open", "kitchen_drawer")
    assert (again.status, again.outcome, again.steps) == ("success", "already_open", 0)
    assert perform(robot, ("grab", "sponge")).status == "success"
    full = operate(robot, "close", "kitchen_drawer")
    assert full.error == "already_holding" and "sponge" in full.message


# --- a closed container hides what is inside -------------------------------------------------------


def test_what_a_closed_container_holds_can_be_neither_seen_nor_reached(robot: RobotSession, world: World) -> None:
    go(robot, "Kitchen Drawer")
    look = perform(robot, ("look_around",))
    assert isinstance(look, LookAroundResult)
    here = next(v for v in look.locations if v.name == "Kitchen Drawer")
    assert here.objects == [] and here.place_positions == []
    assert ("kitchen_drawer", "closed") in {(f.name, f.state) for f in look.furniture}
    grab = perform(robot, ("grab", "sponge"))
    assert isinstance(grab, GrabResult)
    assert (grab.status, grab.error, grab.container) == ("failure", "out_of_reach", "kitchen_drawer")
    assert "kitchen drawer" in grab.message and "closed" in grab.message and "open('kitchen_drawer')" in grab.message
    operate(robot, "open", "kitchen_drawer")
    look = perform(robot, ("look_around",))
    assert isinstance(look, LookAroundResult)
    here = next(v for v in look.locations if v.name == "Kitchen Drawer")
    assert here.objects == ["sponge"] and [p.occupied_by for p in here.place_positions] == ["sponge"]
    assert perform(robot, ("grab", "sponge")).status == "success"


def test_place_into_a_closed_container_fails_and_into_an_open_one_succeeds(robot: RobotSession, world: World) -> None:
    go(robot, "Kitchen Table")
    assert perform(robot, ("grab", "mug")).status == "success"
    go(robot, "Kitchen Cabinet")
    shut = perform(robot, ("place", "Kitchen Cabinet", "inside"))
    assert isinstance(shut, PlaceResult)
    assert (shut.status, shut.error, shut.container) == ("failure", "out_of_reach", "kitchen_cabinet")
    assert "kitchen cabinet" in shut.message
    assert world.holding == "mug"
    # The hand must be free to open: put the mug down on the floor of Kitchen Area Left, then come back.
    go(robot, "Kitchen Area Left")
    assert perform(robot, ("place", "Kitchen Area Left", "floor")).status == "success"
    go(robot, "Kitchen Cabinet")
    assert operate(robot, "open", "kitchen_cabinet").outcome == "opened"
    go(robot, "Kitchen Area Left")
    assert perform(robot, ("grab", "mug")).status == "success"
    go(robot, "Kitchen Cabinet")
    assert perform(robot, ("place", "Kitchen Cabinet", "inside")).status == "success"
    assert operate(robot, "close", "kitchen_cabinet").outcome == "closed"
    mug = world.placement("mug")
    assert (mug.state, mug.position, mug.inside) == ("on_position", "inside", "kitchen_cabinet")
    assert world.furniture("kitchen_cabinet").contents == ["mug"]
    assert "mug" not in {o for v in perform_look(robot).locations for o in v.objects}


def perform_look(robot: RobotSession) -> LookAroundResult:
    look = perform(robot, ("look_around",))
    assert isinstance(look, LookAroundResult)
    return look


# --- partial observability --------------------------------------------------------------------------


def test_look_around_reveals_the_location_the_room_or_the_house(robot: RobotSession, world: World) -> None:
    house = perform_look(robot)
    assert house.observed is None and len(house.locations) == len(world.map.names)
    assert "observed" not in house.model_dump(mode="json")
    robot.observe = "room"
    room = perform_look(robot)
    assert room.observed == "room"
    assert [v.name for v in room.locations] == ["Front Door", "Hallway Area Door", "Kitchen Door", "Living Room Door"]
    assert room.furniture == [] and "this room" in room.message
    robot.observe = "location"
    here = perform_look(robot)
    assert [v.name for v in here.locations] == ["Front Door"] and here.locations[0].objects == ["cube"]
    assert here.locations[0].neighbours == ["Hallway Area Door"]
    go(robot, "Kitchen Area Left")
    robot.observe = "room"
    kitchen = {v.name for v in perform_look(robot).locations}
    assert {"Kitchen Shelf", "Kitchen Table", "Fridge"} <= kitchen and "Front Door" not in kitchen


def test_the_top_down_picture_draws_the_containers_open_or_closed(robot: RobotSession, world: World) -> None:
    from robocog.server.render import render_top_down

    closed = render_top_down(world)
    go(robot, "Kitchen Drawer")
    operate(robot, "open", "kitchen_drawer")
    opened = render_top_down(world)
    assert closed.startswith(b"\x89PNG") and opened.startswith(b"\x89PNG") and opened != closed
    (_, y0, _), _ = world.drawer_or_door_aabb("kitchen_drawer")
    assert y0 < world.scene.container("kitchen_drawer").center[1] - 0.225 - 0.3, "drawn where physics has it"


def test_the_live_viewer_gets_the_containers_and_their_state(robot: RobotSession) -> None:
    from robocog.server.viewer import scene_json, world_json

    drawn = {f["name"] for f in scene_json(robot)["furniture"]}
    assert {"kitchen_drawer", "kitchen_cabinet", "fridge"} <= drawn
    assert [f["state"] for f in world_json(robot)["furniture"]] == ["closed", "closed", "closed"]
