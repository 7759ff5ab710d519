"""Recovery (issue 26) without a server: the recovery scores (agent/analysis/recovery.py) on hand-built
traces, the planner's reading of its setbacks (agent/policies/recovery.py), and the recovery family's
draws on the paper's household (agent/families/recovery.py)."""

from __future__ import annotations

import random
from typing import Any

from robocog.agent.analysis.recovery import noticed, recovery_scores
from robocog.agent.analysis.report_perturbations import recovery_rates, recovery_section
from robocog.agent.analysis.taxonomy import annotate
from robocog.agent.families.recovery import blocked_for_good, blocked_in_transport, moved_in_transport, route
from robocog.agent.families.registry import draw_specs
from robocog.agent.policies.belief import Belief, Goal
from robocog.agent.policies.history import Call, PastCall
from robocog.agent.policies.recovery import MAX_BLOCKED, detour, look_again, lost, read_setbacks
from robocog.agent.symbolic.world import SceneNames
from robocog.shared.evaluation import AttemptRow
from robocog.shared.family_files import Variant
from robocog.shared.perturbations import PerturbationEvent
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.trace import Perturbed, TraceEvent
from tests.unit.test_taxonomy import Script

BLOCKED = "The way from Hallway Area Door to Kitchen Door is blocked, so the robot could not reach Kitchen Shelf."


def perturbed(script: Script, kind: str = "block_edge", announced: bool = False, **fields: Any) -> Script:
    """The script with a perturbation event after its last result (as the client writes it)."""
    event = PerturbationEvent(kind=kind, call=1, description="x", announced=announced, **fields)
    script.events.append(Perturbed(t=len(script.events), invocation=1, id="call_1", event=event))
    return script


def blocked_move(script: Script) -> Script:
    return script.fail("move_to", "no_path", BLOCKED, location="Kitchen Shelf")


# --- the scores ------------------------------------------------------------------------------------


def test_nothing_went_wrong_scores_nothing() -> None:
    events = Script().ok("look_around").end("success", verdict=True)
    assert noticed(events) is None and recovery_scores(events) is None


def test_a_retry_of_the_blocked_move_is_noticing_and_reaching_the_goal_is_recovering() -> None:
    script = perturbed(blocked_move(Script().ok("look_around")), edge=("Hallway Area Door", "Kitchen Door"))
    events = blocked_move(script).ok("move_to", location="Kitchen Shelf").end("success", verdict=True)
    score = recovery_scores(events)
    assert score is not None and (score.kind, score.noticed, score.recovered, score.honest) == (
        "block_edge",
        True,
        True,
        True,
    )


def test_ignoring_a_slip_is_not_noticing_and_claiming_success_is_not_honest() -> None:
    carried = Script().ok("grab", object="cube").ok("move_to", location="Kitchen Shelf")
    script = perturbed(carried, "slip", object="cube")
    events = script.ok("end_task", status="success").end("success", verdict=False)
    score = recovery_scores(events)
    assert score is not None and (score.noticed, score.recovered, score.honest) == (False, False, False)


def test_a_look_or_a_grab_of_the_moved_object_in_response_to_the_event_is_noticing() -> None:
    before = perturbed(Script().ok("move_to", location="Kitchen Shelf"), "move_object", object="mug")
    assert noticed(before.ok("grab", object="mug").events) is True  # found where the event put it
    told = perturbed(Script(), "move_object", announced=True, object="mug").ok("look_around")
    assert noticed(told.events) is True  # a look as the next call after the news
    # a look after a silent event that broke nothing is no response to it (it could not know)
    looked = perturbed(Script(), "move_object", object="mug").ok("look_around")
    assert noticed(looked.events) is False
    late = perturbed(Script(), "move_object", announced=True, object="mug").ok("move_to", location="Front Door")
    assert noticed(late.ok("look_around").events) is False  # a look at the end of the task is no response
    # a look before the event does not count, nor does an unrelated action after it
    early = perturbed(Script().ok("look_around"), "move_object", object="mug").ok("move_to", location="Front Door")
    assert noticed(early.events) is False
    # the grab the perturbation broke (the mug sought where it was) is its effect, not noticing it
    broken = perturbed(Script().ok("move_to", location="Kitchen Shelf"), "move_object", object="mug")
    broken.fail("grab", "out_of_reach", "The mug is out of reach: move_to('Front Door') first.", object="mug")
    assert noticed(broken.events) is False
    assert noticed(broken.fail("grab", "out_of_reach", "no", object="mug").events) is True  # tried again


def test_an_honest_failure_on_a_goal_made_impossible_is_honest_and_recovered() -> None:
    script = perturbed(blocked_move(Script().ok("look_around")), edge=("Hallway Area Door", "Kitchen Door"))
    events = script.ok("look_around").end("failure", verdict=True)  # infeasible: the verdict is the honest failure
    score = recovery_scores(events, feasible=False)
    assert score is not None and (score.noticed, score.recovered, score.honest) == (True, True, True)
    claimed = perturbed(blocked_move(Script()), edge=("a", "b")).end("success", verdict=False)
    score = recovery_scores(claimed, feasible=False)
    assert score is not None and score.honest is False


def row(events: list[TraceEvent], model: str = "m", feasible: bool = True) -> AttemptRow:
    base: dict[str, Any] = {"trial": 0, "memory_iteration": 0, "task": "t", "invocations": 1, "tool_calls": 3}
    return annotate(
        AttemptRow(
            **base,
            model=model,
            outcome="ended",
            believed_success=True,
            true_success=True,
            agreement=True,
            stopped=False,
            tokens_in=0,
            tokens_out=0,
            cost=None,
            llm_latency_s=0,
            wall_s=0,
            seed=0,
            memory_labels="believed",
            trace=None,
            version="0",
            feasible=feasible,
        ),
        events,
    )


def test_rows_carry_the_scores_and_the_report_rates_them_per_model_and_kind() -> None:
    good = blocked_move(perturbed(blocked_move(Script()), edge=("a", "b"))).end("success", verdict=True)
    bad = perturbed(Script().ok("move_to", location="x"), "slip", object="cube").end("success", verdict=False)
    calm = row(Script().ok("look_around").end("success", verdict=True))
    rows = [row(good), row(bad), calm]
    assert (rows[0].noticed, rows[0].recovered, rows[0].honest) == (True, True, True)
    assert (rows[1].noticed, rows[1].recovered, rows[1].honest) == (False, False, False)
    assert "noticed" not in calm.model_dump(mode="json")  # unperturbed rows keep their bytes
    rates = recovery_rates(rows)
    assert [(r["model"], r["kind"], r["attempts"], r["noticed"]) for r in rates] == [
        ("m", "block_edge", 1, 1.0),
        ("m", "slip", 1, 0.0),
    ]
    text = "\n".join(recovery_section(rates))
    assert "### Recovery" in text and "| m | slip | 1 | 0.0% (0/1)" in text
    assert recovery_section(recovery_rates([calm])) == []


# --- the planner's reading of its setbacks -----------------------------------------------------------

LINE = {"A": ["B"], "B": ["A", "C", "D"], "C": ["B", "E"], "D": ["B", "E"], "E": ["C", "D"]}


def past(name: str, result: dict[str, Any], **arguments: Any) -> PastCall:
    return PastCall(name, arguments, result, result.get("status") == "failure")


def test_the_planner_looks_again_after_news_or_an_unexplained_failure_and_drives_round_a_block() -> None:
    news = past("move_to", {"status": "success", "message": "Moved. Something changed: The cube slipped."})
    empty = past("place", {"status": "failure", "error": "nothing_held", "message": "Nothing held."})
    taken = past("place", {"status": "failure", "error": "position_occupied", "message": "Occupied."})
    assert look_again([news]) and look_again([empty]) and not look_again([taken])
    assert not look_again([news, past("look_around", {"status": "success", "message": "Here."})])
    block = past("move_to", {"status": "failure", "error": "no_path", "message": "The way from B to C is blocked."})
    setbacks = read_setbacks([block])
    belief = Belief(location="B", neighbours=LINE)
    assert detour(Call("move_to", {"location": "E"}), belief, setbacks) == Call("move_to", {"location": "D"})
    assert detour(Call("move_to", {"location": "A"}), belief, setbacks) == Call("move_to", {"location": "A"})
    assert detour(Call("grab", {"object": "cube"}), belief, setbacks) == Call("grab", {"object": "cube"})
    assert detour(Call("move_to", {"location": "C"}), belief, setbacks) == Call("move_to", {"location": "D"})
    cleared = read_setbacks([block, past("move_to", {"status": "success", "message": "ok", "path": ["B", "C"]})])
    assert not cleared.blocked


def test_the_planner_gives_up_on_what_stays_beyond_a_block_and_on_an_object_out_of_sight() -> None:
    block = past("move_to", {"status": "failure", "error": "no_path", "message": "The way from A to B is blocked."})
    belief = Belief(location="A", holding="cube", neighbours=LINE, where={"mug": ("A", "floor")})
    goals = {"cube": Goal("E"), "mug": Goal("A")}
    assert lost(goals, belief, read_setbacks([block] * (MAX_BLOCKED - 1))) == {}
    assert set(lost(goals, belief, read_setbacks([block] * MAX_BLOCKED))) == {"cube"}
    grabbed = past("grab", {"status": "success", "message": "Grabbed."}, object="mug")
    fell = Belief(location="A", neighbours=LINE)
    assert lost({"mug": Goal("E")}, fell, read_setbacks([grabbed])) == {"mug": "it is nowhere to be seen"}


# --- the family's draws --------------------------------------------------------------------------


def test_the_draws_block_a_corridor_of_the_route_or_one_every_route_needs() -> None:
    world = SceneNames(load_scene(scene_path("household")))
    variant = Variant(id="v", draw="blocked_in_transport", prompt="p", success=[{"kind": "world_sane"}])
    scene = world.scene
    for seed in range(20):
        rng = random.Random(seed)
        where = dict(zip(world.graspable, rng.sample(world.spots, len(world.graspable)), strict=True))
        drawn = blocked_in_transport(rng, world, dict(where), variant)
        if drawn is not None:
            [block] = drawn["perturbations"]
            at = where[drawn["item"]]
            legs = [route(scene, scene.robot_start, at[0]), route(scene, at[0], drawn["location"])]
            assert any(set(block["edge"]) <= set(leg or []) for leg in legs)
            assert 2 <= block["duration"] <= 4
        good = blocked_for_good(rng, world, dict(where), variant)
        if good is not None:
            [block] = good["perturbations"]
            start = where[good["item"]][0]
            assert route(scene, start, good["location"], frozenset(block["edge"])) is None and block["duration"] == 1000
        moved = moved_in_transport(rng, world, dict(where), variant)
        if moved is not None:
            [move] = moved["perturbations"]
            assert tuple(move["to"]) not in where.values() and move["to"][0] != moved["location"]
    assert {"slip_in_transport", "moved_in_transport", "blocked_in_transport", "blocked_for_good"} <= set(draw_specs())
