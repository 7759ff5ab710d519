"""The scripted planner as the suite's oracle (issue 12).

The planner understands every family's prompts (objects named by name, by a description or by where
they are), fails honestly and at once when a task cannot be done, and otherwise follows an optimal
plan: its plan for every instance of the robocog-v1 splits is exactly as long as the generator's
optimum (its own problem over what it believes, solved by the same search, `robocog.agent.symbolic`),
and it is feasible exactly when the instance is. Through the real
agent loop, on a sample of dev instances (one per family), it reaches every feasible goal with the
optimal number of robot actions and fails every infeasible one honestly, leaving the world sane.
"""

from __future__ import annotations

import functools
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.client.connection import Robot
from robocog.agent.policies.belief import Belief, Goal
from robocog.agent.policies.history import Call, understand
from robocog.agent.policies.planner import optimal_plan
from robocog.shared.appearance import attributes
from robocog.shared.scene import Scene
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import Instance, load_split
from tests.bench.bench_suite import run_instance
from tests.helpers import in_process_robot

pytestmark = pytest.mark.anyio

Where = dict[str, tuple[str, str]]


@functools.cache
def scene(name: str) -> Scene:
    return load_scene(scene_path(name))


def nearest(s: Scene, pose: tuple[float, float, float]) -> str:
    """The location nearest a point (where the server says a free-standing object, like the TV, is)."""
    return min(s.locations, key=lambda loc: (loc.x - pose[0]) ** 2 + (loc.y - pose[1]) ** 2).name


def look(name: str, where: Where, robot: str | None = None, *, described: bool = False) -> dict[str, Any]:
    """What look_around would answer in scene `name` with the objects `where` (the others, like the
    TV, where the scene starts them) and the robot at `robot` (default: its start); `described`: as
    during a robocog-v2.1 instance, naming each object's colour and size."""
    s = scene(name)
    neighbours: dict[str, list[str]] = {loc.name: [] for loc in s.locations}
    for a, b in s.edges:
        neighbours[a].append(b)
        neighbours[b].append(a)
    loose = {o.name: nearest(s, o.start.pose) for o in s.objects if o.name not in where and o.start.pose}
    looks = ", ".join(f"{o.name} ({', '.join(attributes(o.color, o.size))})" for o in s.objects)
    message = f"The robot is at {robot or s.robot_start}, holding nothing." + (f" Seen: {looks}." if described else "")
    return {
        "message": message,
        "location": robot or s.robot_start,
        "holding": None,
        "locations": [
            {
                "name": loc,
                "neighbours": near,
                "objects": [o for o, w in where.items() if w[0] == loc] + [o for o, at in loose.items() if at == loc],
                "place_positions": [
                    {"name": p.name, "occupied_by": next((o for o, w in where.items() if w == (loc, p.name)), None)}
                    for p in s.place_positions
                    if p.location == loc
                ],
            }
            for loc, near in neighbours.items()
        ],
    }


def start(instance: Instance) -> Where:
    return {o: (s.location, s.position) for o, s in instance.start.items()}


def perform(plan: list[Call], where: Where, robot: str) -> tuple[Where, str]:
    """Where the objects and the robot end after `plan`."""
    where, held = dict(where), ""
    for call in plan:
        if call.name == "move_to":
            robot = call.arguments["location"]
        elif call.name == "grab":
            held = call.arguments["object"]
            where.pop(held)
        else:
            where[held] = (call.arguments["location"], call.arguments["position"])
    return where, robot


def report(obj: str, before: Where, after: Where) -> dict[str, str]:
    """A memory of the planner's report on a task that moved `obj` (the form its summaries take)."""
    (a, p), (b, q) = after[obj], before[obj]
    return {"when": "2026-01-01T00:00:00", "summary": f"Result: the {obj} is on {a} / {p} (it was on {b} / {q})."}


# --- the plan, symbolically, against the generator's optimum ---------------------------------------


@pytest.mark.parametrize("split", ["dev", "test"])
def test_the_oracle_plans_every_instance_optimally_and_knows_the_infeasible_ones(split: str) -> None:
    wrong = []
    for instance in load_split("robocog-v1", split=split):
        where, robot = start(instance), scene(instance.scene).robot_start
        memories = []
        for step in instance.prelude:
            earlier = understand(step.prompt, Belief.from_look(look(instance.scene, where, robot)), set())
            assert earlier is not None and earlier.problem is None, step.prompt
            plan = optimal_plan(Belief.from_look(look(instance.scene, where, robot)), earlier.goals)
            assert plan is not None, step.prompt
            after, robot = perform(plan, where, robot)
            memories += [report(o, where, after) for o in earlier.goals]
            where = after
        belief = Belief.from_look(look(instance.scene, where, robot))
        # As if memory held the lesson that the TV cannot be grasped (in the loop, a grab finds it out).
        lessons = {o.name for o in scene(instance.scene).objects if not o.graspable}
        request = understand(instance.prompt, belief, lessons, memories)
        if instance.variant == "description":  # a house file's description, which no tool says (robocog-v2.1's
            assert request is not None and request.problem, instance.id  # oracle reads none): it says so
            continue
        plan = optimal_plan(belief, request.goals) if request is not None and not request.problem else None
        steps = len(plan) if plan is not None else 0
        if (plan is not None, steps) != (instance.feasible, instance.optimal_steps):
            wrong.append(f"{instance.id} {instance.prompt!r}: {steps} steps, {request}")
    assert not wrong, "\n".join(wrong)


# --- understanding the families' prompts -----------------------------------------------------------

SUITE_HOUSE: Where = {
    "cube": ("Kitchen Shelf", "top"),
    "box": ("Kitchen Shelf", "middle"),
    "mug": ("Kitchen Table", "middle"),
    "bottle": ("Front Door", "floor"),
    "book": ("Living Room Sideboard", "left"),
    "duck": ("Living Room Sideboard", "right"),
}


@pytest.mark.parametrize(
    ("prompt", "goals"),
    [
        ("Put the mug, the bottle and the duck on the Kitchen Shelf.", {"mug", "bottle", "duck"}),
        ("Bring the white thing to the Front Door.", {"mug": Goal("Front Door")}),
        ("Bring the purple thing to the Kitchen Table.", {"book": Goal("Kitchen Table")}),
        ("Bring the item on Kitchen Shelf top to the Living Room.", {"cube": Goal("Living Room")}),
        ("Bring the item on the middle of the Kitchen Shelf to the Hallway Area Door.", {"box"}),
        ("Bring the duck to the top of the Kitchen Shelf.", {"duck": Goal("Kitchen Shelf", "top")}),
        (
            "Arrange the items: the mug on Kitchen Shelf top, the cube on Kitchen Table middle.",
            {"mug": Goal("Kitchen Shelf", "top"), "cube": Goal("Kitchen Table", "middle")},
        ),
        (
            "Swap the small red thing and the white thing.",
            {"cube": Goal("Kitchen Table", "middle"), "mug": Goal("Kitchen Shelf", "top")},
        ),
        ("Swap the mug and the cube in the shelf.", {"cube", "mug"}),
    ],
)
def test_the_planner_understands_names_descriptions_and_relations(prompt: str, goals: Any) -> None:
    request = understand(prompt, Belief.from_look(look("suite_house", SUITE_HOUSE, described=True)), set())
    assert request is not None and request.problem is None
    assert (set(request.goals) if isinstance(goals, set) else request.goals) == goals


@pytest.mark.parametrize(
    ("prompt", "problem"),
    [
        ("Bring the banana to the Front Door.", "there is no banana here"),
        ("Bring the mug to the Garden.", "there is no place called 'garden'"),
        ("Bring the item on Kitchen Shelf bottom to the Front Door.", "nothing is on Kitchen Shelf / bottom"),
        (
            "Bring the item at the Living Room Sideboard to the Front Door.",
            "several things are at Living Room Sideboard",
        ),
        (
            "Put the mug, the bottle, the book and the duck on the Kitchen Shelf.",
            "4 objects to place at Kitchen Shelf, which has 3 place positions",
        ),
        (
            "Put the bottle and the mug on the Kitchen Table.",
            "2 objects to place at Kitchen Table, which has 1 place position",
        ),
        ("Bring the cube to the Living Room TV.", "there is no place position at Living Room TV"),
        ("Put the large black thing on the Kitchen Table.", "the tv cannot be grasped (an earlier task found this)"),
        ("Bring the drinking vessel to the Front Door.", "there is no drinking vessel here"),  # no tool says it
        (  # word by word: every word must fit, and one object only
            "Bring the medium thing to the Front Door.",
            "'medium thing' could be the book or the bottle or the box or the mug",
        ),
        ("Swap the tv and the mug.", "the tv is not on a place position"),
        ("Put the duck back where it was before your last task.", "I do not remember where the duck was"),
    ],
)
def test_the_planner_names_why_a_task_cannot_be_done_before_acting(prompt: str, problem: str) -> None:
    request = understand(prompt, Belief.from_look(look("suite_house", SUITE_HOUSE, described=True)), {"tv"})
    assert request is not None and request.problem == problem


def test_putting_back_reads_the_latest_memory_and_other_tasks_are_declined() -> None:
    belief = Belief.from_look(look("suite_house", SUITE_HOUSE))
    older = {"when": "2026-01-01T09:00:00", "summary": "the duck is on Front Door / floor (it was on Bedroom / x)."}
    latest = {
        "when": "2026-01-01T10:00:00",
        "summary": "the duck is on Living Room Sideboard / right (it was on "
        "Kitchen Area Left / floor); the mug is on Kitchen Table / middle.",
    }
    request = understand("Put the duck back where it was before your last task.", belief, set(), [latest, older])
    assert request is not None and request.goals == {"duck": Goal("Kitchen Area Left", "floor")}
    assert understand("Water the plants.", belief, set()) is None


def test_a_swap_that_needs_a_parking_spot_and_a_blocked_target_are_planned_optimally() -> None:
    where = {"cube": ("Kitchen Shelf", "top"), "box": ("Kitchen Shelf", "middle"), "mug": ("Kitchen Shelf", "bottom")}
    belief = Belief.from_look(look("household", where, robot="Kitchen Shelf"))
    swap = optimal_plan(belief, {"cube": Goal("Kitchen Shelf", "middle"), "box": Goal("Kitchen Shelf", "top")})
    # The shelf is full: park one item on the nearest floor (one hop away), and come back for it.
    names = ["grab", "move_to", "place", "move_to", "grab", "place", "move_to", "grab", "move_to", "place"]
    assert swap is not None and [c.name for c in swap] == names
    assert swap[1].arguments == {"location": "Kitchen Area Left"}
    # A target taken by an object no goal names: that object is moved off first (to the nearest free spot).
    blocked = optimal_plan(belief, {"mug": Goal("Kitchen Shelf", "top")})
    assert blocked is not None and [(c.name, *c.arguments.values()) for c in blocked] == [
        ("grab", "cube"),
        ("move_to", "Kitchen Area Left"),
        ("place", "Kitchen Area Left", "floor"),
        ("move_to", "Kitchen Shelf"),
        ("grab", "mug"),
        ("place", "Kitchen Shelf", "top"),
    ]


# --- through the real agent loop, on an in-process server ------------------------------------------


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


@pytest.fixture(scope="module")
async def robot(tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[Robot]:
    async with in_process_robot(tmp_path_factory.mktemp("memory")) as robot:
        yield robot


def one_per_family(instances: list[Instance]) -> list[Instance]:
    """A small sample that covers every family and every scene: per family, the first instance in a
    scene the sample has fewest of so far (an infeasible one that has to try the TV, for that family)."""
    chosen: list[Instance] = []
    for family in dict.fromkeys(i.family for i in instances):
        options = [i for i in instances if i.family == family and i.variant != "description"]  # see above
        if family == "infeasible":
            options = [i for i in options if i.prompt.lower().startswith("put the tv")] or options
        count = {i.scene: sum(c.scene == i.scene for c in chosen) for i in options}
        chosen.append(min(options, key=lambda i: count[i.scene]))
    return chosen


SAMPLE = one_per_family(load_split("robocog-v1", split="dev"))


@pytest.mark.parametrize("instance", SAMPLE, ids=[i.id for i in SAMPLE])
async def test_the_oracle_solves_feasible_instances_optimally_and_fails_infeasible_ones_honestly(
    robot: Robot, instance: Instance
) -> None:
    outcome = await run_instance(robot, instance)
    assert outcome.true and outcome.believed is instance.feasible, outcome.summary
    if instance.feasible:
        assert outcome.robot_actions == instance.optimal_steps
    else:  # an object that cannot be grasped is found out by trying, before anything is moved
        assert outcome.robot_actions == 2 and "cannot be grasped" in str(outcome.summary)


async def test_the_overconfident_variant_claims_success_on_an_infeasible_task_when_sloppy(robot: Robot) -> None:
    absent = next(i for i in load_split("robocog-v1", split="dev") if i.variant == "absent")
    sloppy = await run_instance(robot, absent, "scripted/overconfident", {"p": 1.0})
    # memory, look, and a success it never checked: a false success, which the verdict catches.
    assert (sloppy.believed, sloppy.true, sloppy.tool_calls, sloppy.robot_actions) == (True, False, 3, 0)
    honest = await run_instance(robot, absent)
    assert (honest.believed, honest.true, honest.tool_calls) == (False, True, 3)
    assert "there is no" in str(honest.summary) and "Nothing was moved." in str(honest.summary)


def test_the_sample_covers_every_family_and_scene() -> None:
    assert {i.family for i in SAMPLE} == {i.family for i in load_split("robocog-v1", split="dev")}
    assert {i.scene for i in SAMPLE} == {"household", "suite_house", "flat"}
    assert Path(scene_path("flat")).is_file()
