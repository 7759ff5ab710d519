"""`scripted/faulty`, the instrument: its rates, its seeded draws, the truth it commits, and the
stand-in detector of an ignored perturbation."""

from __future__ import annotations

import pytest

from robocog.agent.analysis.instrument import ClassScore, expected_claim, ignored, scope_of, truth_of
from robocog.agent.policies import faulty, recovery
from robocog.agent.policies.history import History, PastCall
from robocog.agent.policies.offline import OfflineModelError, scripted_turn
from robocog.agent.policies.planner import Call, Planner
from robocog.shared.perturbations import PerturbationEvent
from robocog.shared.trace import ModelTurn, Perturbed, ToolCall
from tests.unit.test_taxonomy import LOOK

TASK = "Put the cube on Kitchen Shelf."
READY = [
    PastCall("search_memory", {"query": TASK}, {"status": "success", "results": []}, False),
    PastCall("look_around", {}, LOOK, False),
    PastCall("add_to_scratchpad", {"text": "plan"}, {"status": "success", "message": "done"}, False),
]


def test_rates_take_one_for_all_and_one_per_class() -> None:
    assert set(faulty.rates({}).values()) == {faulty.DEFAULT_RATE}
    got = faulty.rates({"rate": 0.2, "rate_hallucination": 1.0, "extra_body": {"rate_affordance": 0.0}})
    assert got["hallucination"] == 1.0 and got["affordance"] == 0.0 and got["wrong_order"] == 0.2
    with pytest.raises(ValueError, match="must lie in"):
        faulty.rates({"rate": 1.5})
    with pytest.raises(OfflineModelError, match="scripted/faulty"):
        scripted_turn("scripted/faulty", [], {"rate": "often"})


def test_draws_are_seeded_independent_and_near_their_rates() -> None:
    half = faulty.rates({"rate": 0.5})
    assert faulty.draws(7, half) == faulty.draws(7, half)
    assert faulty.draws(7, faulty.rates({"rate": 1.0})) == frozenset(faulty.CLASSES)
    assert faulty.draws(7, faulty.rates({"rate": 0.0})) == frozenset()
    # one rate changed leaves the other classes' draws alone
    other = {**half, "hallucination": 1.0}
    assert faulty.draws(7, other) - {"hallucination"} == faulty.draws(7, half) - {"hallucination"}
    n = 2000
    for c in faulty.CLASSES:
        share = sum(c in faulty.draws(s, half) for s in range(n)) / n
        assert 0.45 < share < 0.55, (c, share)


def _turn(content: str | None) -> ModelTurn:
    return ModelTurn(t=0.0, invocation=1, step=1, message={"role": "assistant", "content": content}, latency_s=0.0)


def test_the_truth_is_what_the_instrument_logged() -> None:
    """The truth is read from the instrument's own model turns, never from the tool results; a false
    claim is a missing step on a feasible task and a false success on an infeasible one."""
    call = faulty.logged(Call("end_task", {"status": "success"}), "ignored_perturbation", "missing_step")
    assert call.text == "scripted/faulty commits: ignored_perturbation, missing_step"
    events = [_turn(None), _turn("scripted/faulty commits: affordance"), _turn(call.text), _turn("thinking")]
    assert faulty.committed(events) == {"affordance", "ignored_perturbation", "missing_step"}
    assert truth_of(events, feasible=True) == {"affordance", "ignored_perturbation", "missing_step"}
    assert truth_of(events, feasible=False) == {"affordance", "ignored_perturbation", "false_success"}
    assert truth_of([_turn("scripted/faulty commits: false_success")], feasible=True) == {"missing_step"}
    # the message carrying a committed error says so; the planner's own calls carry no text
    assert scripted_turn("scripted/faulty", [], {"rate": 0.0})[0]["content"] is None


def test_the_scope_and_the_rate_set_for_false_claims() -> None:
    assert scope_of(feasible=False, perturbed=False) == {"false_success"}
    assert scope_of(feasible=False, perturbed=True) == {"false_success", "ignored_perturbation"}
    assert "additional_step" in scope_of(feasible=True, perturbed=False)
    assert "additional_step" not in scope_of(feasible=True, perturbed=False, bounded=False)
    r = faulty.rates({"rate": 0.3})
    assert expected_claim(r, feasible=True, perturbed=False) == pytest.approx(0.3)
    assert expected_claim(r, feasible=True, perturbed=True) == pytest.approx(1 - 0.7**2)
    assert expected_claim(r, feasible=False, perturbed=False) == pytest.approx(0.3)
    assert expected_claim(r, feasible=False, perturbed=True) == pytest.approx(1 - 0.7**3)  # the ignoring term too


def test_only_a_surprise_of_the_world_is_a_perturbation_to_ignore() -> None:
    """The planner's look into a container it has just opened is no surprise: an instrument ignoring
    perturbations takes it (it used to end the attempt there, with a claim nobody counted)."""
    opened = PastCall("open", {"furniture": "drawer"}, {"status": "success", "furniture": "drawer"}, False)
    assert not recovery.surprised([*READY, opened])
    assert recovery.surprised([*READY, _failed("grab", "out_of_reach", "The cube is out of reach.", object="cube")])
    news = PastCall("move_to", {"location": "Hallway"}, {"status": "success", "message": "Something changed: x"}, False)
    assert recovery.surprised([*READY, news])
    assert not recovery.surprised(READY)


def test_an_ignored_perturbation_has_no_look_after_it() -> None:
    # announced: a look as the next call responds to it (after a silent one that broke nothing, no call can)
    moved = PerturbationEvent(kind="move_object", call=1, description="The mug moved.", announced=True, object="mug")
    look = ToolCall(t=2.0, invocation=1, id="c2", name="look_around", arguments={}, raw_arguments="{}")
    grab = ToolCall(t=1.0, invocation=1, id="c1", name="grab", arguments={"object": "mug"}, raw_arguments="")
    event = Perturbed(t=1.5, invocation=1, id="c1", event=moved)
    assert ignored([grab, event]) and not ignored([grab, event, look]) and not ignored([grab, look])


def test_a_class_score_without_cases_is_not_measured() -> None:
    assert ClassScore("x", 0, 0, 0).precision is None and ClassScore("x", 0, 0, 0).recall is None
    assert ClassScore("x", 3, 1, 0).precision == 0.75 and ClassScore("x", 3, 1, 1).recall == 0.75


def _failed(name: str, code: str, message: str = "no", **arguments: str) -> PastCall:
    return PastCall(name, arguments, {"status": "failure", "error": code, "message": message}, True)


def test_the_planner_inside_reads_the_history_without_the_instruments_errors() -> None:
    """The instrument's own failed call is no surprise of the world: the planner inside neither
    looks again after it nor (ignoring perturbations) takes it for one and ends; a failure it did
    not cause still is one."""
    faults = frozenset({"hallucination", "ignored_perturbation"})
    instrument = faulty.Faulty(Planner(), faults=faults, seed=1)
    fake = Call("move_to", {"location": faulty.FAKE_LOCATION})
    assert instrument(History(TASK, READY, [])) == faulty.logged(fake, "hallucination")
    own = [*READY, _failed("move_to", "unknown_location", location=faulty.FAKE_LOCATION)]
    assert Planner()(History(TASK, own, [])) == Call("look_around")  # the plain planner looks again
    assert instrument(History(TASK, own, [])) == Call("grab", {"object": "cube"})
    world = [*own, _failed("grab", "out_of_reach", "The cube is out of reach from Front Door.", object="cube")]
    ended = instrument(History(TASK, world, []))
    assert ended.name == "end_task" and ended.arguments["status"] == "success"
    assert ended == faulty.logged(ended, "ignored_perturbation", "missing_step")  # a claim with steps undone
