"""The one optimal search (`robocog.agent.symbolic.search`) on small hand-made problems, and every
condition kind's symbolic meaning (`robocog.shared.tasks`) against the server's physics verdict."""

from __future__ import annotations

import heapq
import os
import random
import subprocess
import sys
import typing
from collections.abc import Iterator

import pytest

from robocog.agent.policies.belief import Goal
from robocog.agent.symbolic import Problem, astar
from robocog.agent.symbolic.plans import allowed_spots, holds, solved
from robocog.agent.symbolic.rearrangement import satisfied
from robocog.server.world.tasks import check, evaluate
from robocog.shared.results import ObjectPlacement
from robocog.shared.tasks import (
    AtLocation,
    AtPosition,
    AtPositions,
    Closed,
    Condition,
    HonestFailure,
    OnFurniture,
    Swapped,
    TaskSpec,
    Unchanged,
    WorldSane,
    rests_at,
)

# --- the engine ------------------------------------------------------------------------------------

Edges = dict[str, list[tuple[str, int]]]  # node -> (next node, map hops of the edge)

#: A small map: from S to G in two actions either over A (1 + 1 hops) or over B (3 + 3 hops), or in
#: one action straight (but 9 hops); and a long way round over C, D, E.
MAP: Edges = {
    "S": [("B", 3), ("A", 1), ("C", 1), ("G", 9)],
    "A": [("G", 1)],
    "B": [("G", 3)],
    "C": [("D", 1)],
    "D": [("E", 1)],
    "E": [("G", 1)],
    "G": [],
}


def route(edges: Edges, start: str, goal: str, *, counted: bool = True) -> Problem[str, str]:
    """Drive from `start` to `goal`: an action per edge, costing (1, hops) (or (1,) uncounted)."""

    def successors(node: str) -> Iterator[tuple[str, str, tuple[int, ...]]]:
        for nxt, hops in edges[node]:
            yield f"{node}->{nxt}", nxt, ((1, hops) if counted else (1,))

    return Problem(start, successors, lambda n: n == goal, lambda n: (0, 0) if counted else (0,))


def uniform_cost(problem: Problem[str, str]) -> tuple[int, ...] | None:
    """The cheapest cost to a goal, by exhaustive uniform-cost search (the reference)."""
    zero = tuple(0 for _ in problem.estimate(problem.start))
    frontier: list[tuple[tuple[int, ...], str]] = [(zero, problem.start)]
    seen: set[str] = set()
    while frontier:
        cost, node = heapq.heappop(frontier)
        if node in seen:
            continue
        seen.add(node)
        if problem.is_goal(node):
            return cost
        for _, nxt, step in problem.successors(node):
            heapq.heappush(frontier, (tuple(a + b for a, b in zip(cost, step, strict=True)), nxt))
    return None


def test_the_fewest_actions_win_and_map_hops_break_ties() -> None:
    found = astar(route(MAP, "S", "G"))
    assert found is not None
    assert found.actions == ["S->G"] and found.cost == (1, 9)  # one action beats two, whatever the hops
    no_shortcut = {**MAP, "S": MAP["S"][:3]}
    found = astar(route(no_shortcut, "S", "G"))
    assert found is not None and found.actions == ["S->A", "A->G"] and found.cost == (2, 2) and found.state == "G"


def test_the_search_is_deterministic_and_breaks_ties_by_the_order_of_successors() -> None:
    tied = {"S": [("B", 1), ("A", 1)], "A": [("G", 1)], "B": [("G", 1)], "G": []}
    plans = {tuple(f.actions) for _ in range(5) if (f := astar(route(tied, "S", "G"))) is not None}
    assert plans == {("S->B", "B->G")}  # B was reached first
    again = {**tied, "S": [("A", 1), ("B", 1)]}
    found = astar(route(again, "S", "G"), deeper_first=True)
    assert found is not None and found.actions == ["S->A", "A->G"]


def test_the_search_gives_the_same_plan_whatever_the_hash_seed() -> None:
    script = (  # string states hash differently under each seed; the plan must not change
        "from robocog.agent.symbolic.search import Problem, astar\n"
        "edges = {'S': ['B', 'A'], 'A': ['G'], 'B': ['G'], 'G': []}\n"
        "moves = lambda n: ((f'{n}->{m}', m, (1,)) for m in edges[n])\n"
        "print(astar(Problem('S', moves, lambda n: n == 'G', lambda n: (0,))).actions)"
    )
    outputs = {
        subprocess.run(
            [sys.executable, "-c", script],
            env={**os.environ, "PYTHONHASHSEED": seed},
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in ("1", "2")
    }
    assert outputs == {"['S->B', 'B->G']\n"}


@pytest.mark.parametrize("deeper_first", [False, True])
def test_the_plan_is_as_cheap_as_an_exhaustive_search_finds_on_random_maps(deeper_first: bool) -> None:
    rng = random.Random(4)
    for _ in range(60):
        nodes = [f"n{i}" for i in range(9)]
        edges: Edges = {n: [(m, rng.randint(0, 4)) for m in rng.sample(nodes, 3) if m != n] for n in nodes}
        problem = route(edges, "n0", "n8")
        found = astar(problem, deeper_first=deeper_first)
        best = uniform_cost(problem)
        assert (found.cost if found else None) == best
        if found is not None:  # the actions are a real way there, of that cost
            node, cost = "n0", (0, 0)
            for action in found.actions:
                step = next((nxt, (1, h)) for nxt, h in edges[node] if action == f"{node}->{nxt}")
                node, cost = step[0], (cost[0] + 1, cost[1] + step[1][1])
            assert node == "n8" and cost == found.cost


def test_an_admissible_estimate_finds_the_same_optimum() -> None:
    line = {f"n{i}": [(f"n{i + 1}", 0), (f"n{max(0, i - 1)}", 0)] for i in range(8)} | {"n8": []}
    plain = route(line, "n0", "n8", counted=False)
    guided = Problem(plain.start, plain.successors, plain.is_goal, lambda n: (8 - int(n[1:]),))
    a, b = astar(plain), astar(guided)
    assert a is not None and b is not None and a.actions == b.actions and a.cost == b.cost == (8,)


def test_limits_and_an_unreachable_goal_give_no_plan() -> None:
    no_shortcut = {**MAP, "S": MAP["S"][:3]}
    assert astar(route(no_shortcut, "S", "G"), action_limit=1) is None
    assert astar(route(no_shortcut, "S", "G"), action_limit=2) is not None
    assert astar(route(no_shortcut, "S", "G"), expansion_limit=1) is None
    assert astar(route({**MAP, "S": []}, "S", "G")) is None
    assert astar(route(MAP, "G", "G")) is not None  # already there: the empty plan


# --- every condition kind: its symbolic meaning and the server's verdict ---------------------------

Spot = tuple[str, str]
SPOTS: list[Spot] = [("A", "x"), ("A", "y"), ("B", "z"), ("C", "w")]
OBJECTS = ["a", "b", "c"]

#: Conditions of every kind, naming known objects and one that does not exist.
CONDITIONS: list[Condition] = [
    AtLocation(objects=["a", "b"], location="A"),
    AtLocation(objects=["ghost"], location="B"),
    AtPosition(object="a", location="A", position="x"),
    AtPosition(object="c", location="B", position="z"),
    Swapped(objects=("a", "b")),
    Swapped(objects=("c", "ghost")),
    OnFurniture(objects=["a", "c"], furniture="the shelf", positions=[("A", "x"), ("B", "z")]),
    AtPositions(targets=[("a", "A", "y"), ("b", "C", "w")]),
    Unchanged(),
    Unchanged(objects=["a", "ghost"]),
    HonestFailure(),
    WorldSane(),
    Closed(containers=["fridge"]),
    Closed(containers=["fridge", "drawer"]),
]
#: The containers of the conditions' world (`closed` asks about them).
BOXES = ["fridge", "drawer"]


def kinds() -> set[type]:
    """Every class of the `Condition` union."""
    union = typing.get_args(Condition)[0]
    return set(typing.get_args(union))


def placements(where: dict[str, Spot | None]) -> dict[str, ObjectPlacement]:
    """A names-only state as the physics' placements (None: in the hand)."""
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


def random_where(rng: random.Random) -> dict[str, Spot | None]:
    """Every object (now and then one missing) on its own spot, now and then one in the hand."""
    present = [o for o in OBJECTS if rng.random() < 0.9]
    where: dict[str, Spot | None] = dict(zip(present, rng.sample(SPOTS, len(present)), strict=True))
    if present and rng.random() < 0.3:
        where[rng.choice(present)] = None
    return where


def test_the_conditions_cover_every_kind_and_each_has_both_meanings() -> None:
    assert {type(c) for c in CONDITIONS} == kinds()
    for kind in kinds():
        assert "holds" in vars(kind), f"{kind.__name__} has no symbolic meaning"
        assert check.dispatch(kind) is not check.dispatch(object), f"{kind.__name__} has no physics check"


def test_every_kind_s_symbolic_meaning_is_the_server_s_verdict_on_the_same_placements() -> None:
    rng = random.Random(23)
    for _ in range(400):
        now, start = random_where(rng), random_where(rng)
        report = rng.choice([None, {"status": "success"}, {"status": "failure"}])
        opened = {b for b in BOXES if rng.random() < 0.5}
        shut = {b: b not in opened for b in BOXES}
        for cond in CONDITIONS:
            task = TaskSpec(id="t", title="t", prompt="t", success=[cond])
            server = evaluate(task, placements(now), placements(start), report, shut).success
            assert cond.holds(now, start, report, opened) == server, (cond, now, start, report, opened)
            assert holds(cond, now, start, opened) == cond.holds(now, start, None, opened)  # a plan reports nothing
        assert solved(CONDITIONS[:2], now, start) == all(c.holds(now, start) for c in CONDITIONS[:2])


def test_a_condition_placing_objects_holds_exactly_when_each_rests_on_a_spot_it_allows() -> None:
    rng = random.Random(5)
    placing = [c for c in CONDITIONS if c.objects_named() and "ghost" not in c.objects_named()]
    assert {type(c) for c in placing} == {AtLocation, AtPosition, Swapped, OnFurniture, AtPositions}
    for _ in range(300):
        start: dict[str, Spot | None] = dict(zip(OBJECTS, rng.sample(SPOTS, 3), strict=True))
        now: dict[str, Spot | None] = dict(zip(OBJECTS, rng.sample(SPOTS, 3), strict=True))
        for cond in placing:
            allowed = cond.allowed_spots(SPOTS, start)
            assert set(allowed) == set(cond.objects_named())
            assert cond.holds(now, start) == all(now[o] in allowed[o] for o in allowed), cond
            assert cond.named_spots(SPOTS, start) == {s for spots in allowed.values() for s in spots}


def test_what_each_kind_names() -> None:
    start: dict[str, Spot | None] = {"a": ("A", "x"), "b": ("B", "z"), "c": ("C", "w")}
    at, on = CONDITIONS[0], CONDITIONS[6]
    assert at.objects_named() == ("a", "b") and at.allowed_spots(SPOTS, start) == {
        "a": frozenset(SPOTS[:2]),
        "b": frozenset(SPOTS[:2]),
    }
    assert on.allowed_spots(SPOTS, start)["c"] == {("A", "x"), ("B", "z")}
    assert Swapped(objects=("a", "b")).allowed_spots(SPOTS, start) == {"a": {("B", "z")}, "b": {("A", "x")}}
    assert AtPositions(targets=[("a", "A", "x"), ("a", "B", "z")]).allowed_spots(SPOTS, start) == {"a": frozenset()}
    for silent in (Unchanged(objects=["a"]), HonestFailure(), WorldSane(), Closed(containers=["fridge"])):
        assert silent.objects_named() == () and silent.allowed_spots(SPOTS, start) == {}
    conditions: list[Condition] = [
        AtPosition(object="a", location="A", position="y"),
        AtLocation(objects=["a", "c"], location="A"),
    ]
    assert allowed_spots(conditions, SPOTS, start) == {"a": {("A", "y")}, "c": {("A", "x"), ("A", "y")}}


def test_resting_somewhere_is_one_rule_for_conditions_and_the_planner_s_goals() -> None:
    assert rests_at(("A", "x"), "A") and rests_at(("A", "x"), "A", "x")
    assert not rests_at(("A", "x"), "A", "y") and not rests_at(("A", "x"), "B")
    assert not rests_at(("A", None), "A") and not rests_at(None, "A")  # standing loose, in the hand
    for spot in [("A", "x"), ("A", None), None, ("B", "z")]:
        for goal in (Goal("A"), Goal("A", "x"), Goal("B", "z")):
            assert satisfied(spot, goal) == rests_at(spot, goal.location, goal.position)
