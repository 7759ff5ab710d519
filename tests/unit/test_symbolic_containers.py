"""Containers in the symbolic world (issue 26): the generator's optimal plans open and close (one
action each; reaching inside needs the container open, opening needs the hand free), the `closed`
condition's two meanings, the planner's rearrangement with containers and unseen insides, and the
planner's belief and search under partial observation."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robocog.agent.families.reading import Request
from robocog.agent.policies import explore, sightings
from robocog.agent.policies.belief import Belief, Goal
from robocog.agent.policies.history import History, PastCall, current_belief
from robocog.agent.symbolic.plans import optimal_plan, solved
from robocog.agent.symbolic.rearrangement import UNSEEN
from robocog.agent.symbolic.rearrangement import optimal_plan as believed_plan
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.server.world.tasks import evaluate
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.tasks import AtLocation, Closed, Condition, TaskSpec

KITCHEN = SceneNames(load_scene(scene_path("kitchen_plus")))
START: Where = {
    "cube": ("Front Door", "floor"),
    "box": ("Living Room", "floor"),
    "mug": ("Kitchen Table", "middle"),
    "sponge": ("Kitchen Drawer", "inside"),
    "bottle": ("Fridge", "inside"),
}


def test_the_scene_s_containers_and_the_positions_inside_them() -> None:
    assert KITCHEN.containers == {
        "kitchen_drawer": "Kitchen Drawer",
        "kitchen_cabinet": "Kitchen Cabinet",
        "fridge": "Fridge",
    }
    assert KITCHEN.inside[("Fridge", "inside")] == "fridge" and ("Kitchen Table", "middle") not in KITCHEN.inside


def test_putting_into_a_container_opens_it_first_with_the_hand_free_and_closing_costs_one_more() -> None:
    into: list[Condition] = [AtLocation(objects=["mug"], location="Kitchen Cabinet")]
    found = optimal_plan(KITCHEN, dict(START), "Kitchen Table", into)
    assert found is not None
    plan, where, robot = found
    assert plan == [
        ("move_to", "Kitchen Cabinet"),
        ("open", "kitchen_cabinet"),
        ("move_to", "Kitchen Table"),
        ("grab", "mug"),
        ("move_to", "Kitchen Cabinet"),
        ("place", "Kitchen Cabinet/inside"),
    ]
    assert where["mug"] == ("Kitchen Cabinet", "inside") and robot == "Kitchen Cabinet"
    shut = optimal_plan(KITCHEN, dict(START), "Kitchen Table", [*into, Closed(containers=["kitchen_cabinet"])])
    assert shut is not None and shut[0] == [*plan, ("close", "kitchen_cabinet")]


def test_taking_out_needs_the_container_open_and_clearing_the_target_comes_first() -> None:
    out: list[Condition] = [AtLocation(objects=["sponge"], location="Kitchen Table")]
    found = optimal_plan(KITCHEN, dict(START), "Front Door", out)
    assert found is not None
    # The table is taken by the mug: the hand is free to open the drawer only once the mug is put away.
    assert found[0] == [
        ("move_to", "Kitchen Table"),
        ("grab", "mug"),
        ("move_to", "Hallway Area Door"),
        ("place", "Hallway Area Door/floor"),
        ("move_to", "Kitchen Drawer"),
        ("open", "kitchen_drawer"),
        ("grab", "sponge"),
        ("move_to", "Kitchen Table"),
        ("place", "Kitchen Table/middle"),
    ]


def test_closed_holds_symbolically_as_the_server_judges_the_joints() -> None:
    cond = Closed(containers=["fridge"])
    task = TaskSpec(id="t", title="t", prompt="t", success=[cond])
    for opened in (set(), {"fridge"}, {"kitchen_drawer"}):
        shut = {b: b not in opened for b in KITCHEN.containers}
        assert (
            cond.holds(START, START, None, opened)
            == evaluate(task, {}, {}, None, shut).success
            == ("fridge" not in opened)
        )
        assert solved([cond], START, START, opened) == ("fridge" not in opened)
    verdict = evaluate(task, {}, {}, None, None)  # a world without containers
    assert not verdict.success and "no container 'fridge'" in verdict.reason


# --- the planner's belief and plans ----------------------------------------------------------------

#: Per location: its neighbours, its positions (-> occupant) and the objects standing loose there.
Layout = Mapping[str, tuple[list[str], Mapping[str, str | None], list[str]]]


def look(
    here: str,
    locations: Layout,
    boxes: dict[str, tuple[str, str]],
    *,
    partial: bool,
) -> dict[str, Any]:
    """A look_around result: per location (neighbours, position -> occupant, loose objects), and the
    containers (name -> (location, state))."""
    return {
        "location": here,
        "holding": None,
        "observed": "location" if partial else None,
        "locations": [
            {
                "name": name,
                "neighbours": near,
                "objects": [o for o in spots.values() if o] + loose,
                "place_positions": [{"name": p, "occupied_by": o} for p, o in spots.items()],
            }
            for name, (near, spots, loose) in locations.items()
        ],
        "furniture": [{"name": b, "kind": "drawer", "location": loc, "state": s} for b, (loc, s) in boxes.items()],
    }


HALL: Layout = {"Hall": (["Kitchen", "Drawer"], {"floor": None}, [])}
KITCHEN_SEEN: Layout = {"Kitchen": (["Hall"], {"table": "mug"}, [])}
DRAWER_SHUT: Layout = {"Drawer": (["Hall"], {}, [])}


def test_a_partial_look_adds_to_the_belief_and_what_is_shut_in_stays_believed() -> None:
    belief = Belief.from_look(look("Hall", HALL, {}, partial=True))
    assert belief.seen == {"Hall"} and "Kitchen" not in belief.positions
    belief = sightings.merge(belief, look("Kitchen", KITCHEN_SEEN, {}, partial=True))
    assert belief.seen == {"Hall", "Kitchen"} and belief.where["mug"] == ("Kitchen", "table")
    assert belief.neighbours["Hall"] == ["Kitchen", "Drawer"] and belief.location == "Kitchen"
    belief = sightings.merge(
        belief,
        look("Drawer", {"Drawer": (["Hall"], {"inside": "sock"}, [])}, {"drawer": ("Drawer", "open")}, partial=True),
    )
    assert belief.where["sock"] == ("Drawer", "inside") and not belief.closed
    shut = sightings.merge(belief, look("Drawer", DRAWER_SHUT, {"drawer": ("Drawer", "closed")}, partial=True))
    assert shut.where["sock"] == ("Drawer", "inside") and shut.closed == {"drawer"}  # out of sight, still there


def test_the_planner_s_plan_opens_a_container_it_has_never_seen_inside() -> None:
    whole = {**HALL, **KITCHEN_SEEN, **DRAWER_SHUT}
    belief = Belief.from_look(look("Hall", whole, {"drawer": ("Drawer", "closed")}, partial=False))
    plan = believed_plan(belief, {"mug": Goal("Drawer")})
    assert plan == [
        ("move_to", {"location": "Drawer"}),
        ("open", {"furniture": "drawer"}),
        ("move_to", {"location": "Kitchen"}),
        ("grab", {"object": "mug"}),
        ("move_to", {"location": "Drawer"}),
        ("place", {"location": "Drawer", "position": UNSEEN}),
    ]
    belief.expected["sock"] = "drawer"  # the task says the sock is in the drawer
    assert [a for a, _ in believed_plan(belief, {"sock": Goal("Hall")}) or []] == [
        "move_to",
        "open",
        "grab",
        "move_to",
        "place",
    ]


def test_the_search_looks_opens_and_drives_to_the_nearest_unseen_place_then_gives_up() -> None:
    find = Request("search", {"sock": Goal("hall")}, explore=True)
    belief = Belief.from_look(look("Hall", HALL, {}, partial=True))
    request = explore.ground(find, belief)
    assert request.goals == {"sock": Goal("Hall")}
    assert explore.next_move(request, request.goals, belief) == explore.Move("move_to", {"location": "Drawer"})
    belief.location = "Drawer"
    assert explore.next_move(request, request.goals, belief) == explore.Move("look_around")
    belief = sightings.merge(belief, look("Drawer", DRAWER_SHUT, {"drawer": ("Drawer", "closed")}, partial=True))
    assert explore.next_move(request, request.goals, belief) == explore.Move("open", {"furniture": "drawer"})
    belief.closed.clear()
    assert explore.next_move(request, request.goals, belief) == explore.Move("move_to", {"location": "Kitchen"})
    belief = sightings.merge(belief, look("Kitchen", KITCHEN_SEEN, {}, partial=True))
    move = explore.next_move(request, request.goals, belief)
    assert move is not None and move.tool is None and "did not find the sock" in move.reason


def test_a_place_refused_by_a_closed_container_tells_the_planner_which_to_open() -> None:
    """The result names the furniture in its `container` (contract 4.3): the planner believes it
    closed (someone shut it) whatever the message's words; a place beyond the arm names none."""
    opened = look("Drawer", {"Drawer": (["Hall"], {"inside": None}, [])}, {"drawer": ("Drawer", "open")}, partial=False)
    where = {"location": "Drawer", "position": "inside"}
    for container, closed in (("drawer", {"drawer"}), (None, set())):
        refused = {"status": "failure", "error": "out_of_reach", "message": "Not now.", "container": container}
        calls = [PastCall("look_around", {}, opened, False), PastCall("place", where, refused, True)]
        _, belief = current_belief(History("Put the sock in the drawer.", calls, []))
        assert belief is not None and belief.closed == closed
