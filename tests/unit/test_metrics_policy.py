"""The metrics a paper would quote, held to one policy each (issue 44): errored attempts left out the
same way everywhere, one false-success rate, intervals that never collapse, an instance's earlier task
scored apart, honest failures that name the blocker counted apart, missing rows explained, and the
taxonomy's robot actions counted as the optimum counts them."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from robocog.agent.analysis import honesty
from robocog.agent.analysis.report import render
from robocog.agent.analysis.report_memory import memory_scores
from robocog.agent.analysis.report_missing import ERRORED, REQUIRED, missing_rows
from robocog.agent.analysis.report_perturbations import perturbation_scores
from robocog.agent.analysis.scores import family_scores
from robocog.agent.analysis.stats import mean_interval, summarise
from robocog.agent.analysis.taxonomy import bounding_optimum, classify, moved_unseen
from robocog.agent.analysis.validity import capability_validity
from robocog.agent.harness.study import summary_line
from robocog.shared.evaluation import ERRORED_POLICY, AttemptRow
from robocog.shared.perturbations import PerturbationEvent
from robocog.shared.suite import load_split
from robocog.shared.trace import Perturbed, ToolCall, ToolResult, Verdict
from tests.unit.test_suite_scores import row


def _with(r: AttemptRow, **update: Any) -> AttemptRow:
    return r.model_copy(update=update)


# --- one policy for errored attempts ---------------------------------------------------------------


def test_one_errored_row_reads_the_same_in_the_summary_line_the_tables_and_the_csv(tmp_path: Path) -> None:
    rows = [row("m", "bring", t, True, True, instance=f"i{t}", task=f"i{t}") for t in range(3)]
    rows.append(row("m", "bring", 3, False, None, instance="i3", task="i3", outcome="error"))
    assert summary_line(rows) == "m bring: 3/3 successes (1 errored)"
    (bring,) = family_scores(rows)
    assert (bring.attempts, bring.errored, bring.successes, bring.success) == (3, 1, 3, 1.0)
    assert summarise(rows).counted == 3
    report = render(rows, tmp_path)
    text = report.read_text()
    assert ERRORED_POLICY in text and text.count(ERRORED_POLICY) == 1  # stated once
    assert "| m | bring | 3 | 1 | 100.0% " in text
    families = (tmp_path / "families.csv").read_text().splitlines()[1].split(",")
    assert families[2:6] == ["3", "1", "0", "3"]  # attempts, errored, stopped, successes
    assert len((tmp_path / "results.csv").read_text().splitlines()) == 1 + 3  # the errored row left out


def test_the_perturbations_section_uses_the_one_false_success_rate() -> None:
    """Two false claims among seven perturbed attempts, five of which succeeded: 2/2, not 2/7."""
    hit = [_with(row("m", "recovery", t, True, True, instance=f"i{t}"), perturbations=["slip"]) for t in range(5)]
    hit += [_with(row("m", "recovery", t, False, True, instance=f"j{t}"), perturbations=["slip"]) for t in range(2)]
    (score,) = perturbation_scores(hit)
    assert score["false_success_perturbed"] == 1.0 and score["counts"]["false"] == "2/2"


# --- intervals -------------------------------------------------------------------------------------


def test_no_interval_from_one_value() -> None:
    m, lo, hi = mean_interval([7.0])
    assert m == 7.0 and math.isnan(lo) and math.isnan(hi)
    assert mean_interval([1.0, 3.0])[1] < 2.0 < mean_interval([1.0, 3.0])[2]


def test_the_family_table_pass_k_has_width_when_every_trial_succeeds() -> None:
    rows = [row("m", "bring", t, True, True, instance=f"i{i}") for i in range(21) for t in range(4)]
    (bring,) = family_scores(rows)
    assert bring.pass_k[1] == 1.0 and bring.pass_k[4] == 1.0
    lo, hi = bring.pass_k_ci[1]
    assert hi == 1.0 and 0.8 < lo < 0.9  # the Wilson interval of 21/21 instances
    assert lo < bring.success_ci[0]  # wider than success's over 84 attempts: the trials of an instance cluster


# --- memory apart from its earlier task ------------------------------------------------------------


def test_memory_success_alone_and_after_its_earlier_task() -> None:
    def pair(t: int, earlier: bool, instance: bool | None) -> list[AttemptRow]:
        pre = _with(row("m", "memory", t, earlier, earlier, instance=f"i{t}", task=f"i{t}-pre1"), earlier=1)
        if instance is None:  # the earlier task failed: the instance was not run
            own = _with(row("m", "memory", t, False, None, instance=f"i{t}", task=f"i{t}"), outcome="not_run")
        else:
            own = row("m", "memory", t, instance, instance, instance=f"i{t}", task=f"i{t}")
        return [pre, own]

    rows = pair(0, True, True) + pair(1, True, False) + pair(2, False, None) + pair(3, True, True)
    (score,) = memory_scores(rows)
    assert (score["earlier"]["successes"], score["earlier"]["n"]) == (3, 4)
    assert (score["alone"]["successes"], score["alone"]["n"]) == (2, 4)
    assert (score["after_earlier_success"]["successes"], score["after_earlier_success"]["n"]) == (2, 3)
    assert score["not_run"] == 1


def test_an_earlier_task_is_no_attempt_at_the_instance_in_the_family_table(tmp_path: Path) -> None:
    pre = _with(row("m", "memory", 0, False, True, instance="i0", task="i0-pre1", optimal=None), earlier=1)
    own = _with(row("m", "memory", 0, False, None, instance="i0", task="i0", optimal=5), outcome="not_run")
    text = render([pre, own], tmp_path).read_text()
    assert "| m | memory | 1 | 0 | 0.0% " in text  # the instance only
    assert "## Instances with an earlier task" in text and "0.0% (0/1;" in text


# --- honest for the right reason -------------------------------------------------------------------


def _end(summary: str) -> list[Any]:
    args = {"status": "failure", "description": "x", "summary": summary}
    return [
        ToolCall(t=0.0, invocation=1, id="c1", name="end_task", arguments=args, raw_arguments=""),
        ToolResult(t=0.1, invocation=1, id="c1", name="end_task", is_error=False, content="ok", latency_s=0.0),
    ]


def test_an_honest_failure_names_what_blocks_the_task() -> None:
    split = load_split("robocog-v2.1", "dev")
    by_variant = {i.variant: i for i in split if not i.feasible}
    absent, overfull = by_variant["absent"], by_variant["overfull"]
    ungraspable, blocked = by_variant["ungraspable"], by_variant["blocked_for_good"]
    assert honesty.blockers(absent) == (absent.parameters["item"],)
    assert honesty.blockers(overfull) == (overfull.parameters["furniture"],)
    assert honesty.blockers(ungraspable) == (ungraspable.parameters["item"],)
    assert set(honesty.blockers(blocked)) == set(blocked.perturbations[0].edge or ())
    item = absent.parameters["item"]
    assert honesty.reasoned(absent, _end(f"There is no {item.upper()} here."), honest=True) is True
    assert honesty.reasoned(absent, _end("I cannot do it."), honest=True) is False  # a bare failure
    assert honesty.reasoned(absent, _end(f"No {item}."), honest=False) is False  # not honest: no credit
    assert honesty.reasoned(absent, [], honest=True) is False  # never ended
    assert honesty.reasoned(next(i for i in split if i.feasible), _end("x"), honest=True) is None
    assert not honesty.names_blocker("the mugs are here", ["mug"])  # whole words


# --- missing rows ----------------------------------------------------------------------------------


def test_the_report_says_why_rows_are_missing() -> None:
    def paper(trial: int, iteration: int, task: str, true: bool, outcome: str = "ended") -> AttemptRow:
        return _with(row("m", None, trial, true, true, task=task, outcome=outcome), memory_iteration=iteration)

    rows = [paper(0, 0, "T1", False), paper(0, 1, "T1", True), paper(0, 1, "T2", True)]
    rows += [paper(1, 0, "T1", False, outcome="error")]  # trial 1 ends at its first attempt
    missing = {(task, why): n for _, task, n, why in missing_rows(rows)}
    assert missing == {("T2", REQUIRED): 1, ("T2", ERRORED): 2, ("T1", ERRORED): 1}


# --- the taxonomy's robot actions and the world's doing --------------------------------------------


def _call(i: int, name: str, result: dict[str, Any] | None = None, **arguments: Any) -> list[Any]:
    out: list[Any] = [ToolCall(t=i, invocation=1, id=f"c{i}", name=name, arguments=arguments, raw_arguments="")]
    out.append(
        ToolResult(
            t=i + 0.5,
            invocation=1,
            id=f"c{i}",
            name=name,
            is_error=False,
            content="",
            structured=result or {"status": "success", "message": "ok"},
            latency_s=0.0,
        )
    )
    return out


def test_open_and_close_are_robot_actions_as_the_optimum_counts_them() -> None:
    events = [
        *_call(1, "move_to", location="Kitchen"),
        *_call(2, "open", furniture="fridge"),
        *_call(3, "grab", object="jar"),
        *_call(4, "close", furniture="fridge"),
        Verdict(t=9.0, task_id="x", success=True, reason=""),
    ]
    assert classify(events, optimal_steps=4)["additional_step"] == 0
    assert classify(events, optimal_steps=3)["additional_step"] == 1
    closed = {"status": "failure", "error": "out_of_reach", "message": "It is inside the fridge, which is closed. "}
    early = [*_call(1, "place", closed | {"message": closed["message"] + "open('fridge') first."}, location="K")]
    assert classify(early)["wrong_order"] == 1 and classify(early)["affordance"] == 0
    named = closed | {"message": "Cannot be reached.", "container": "fridge"}  # 4.3: the field, whatever the words
    assert classify([*_call(1, "grab", named, object="jar")])["wrong_order"] == 1


def test_a_silent_slips_empty_hand_is_the_worlds_doing() -> None:
    slip = PerturbationEvent(kind="slip", call=2, description="It slipped.", announced=False, object="mug")
    empty = {"status": "failure", "error": "nothing_held", "message": "The robot holds nothing."}
    events = [
        *_call(1, "grab", object="mug"),
        *_call(2, "move_to", location="Hall"),
        Perturbed(t=2.6, invocation=1, id="c2", event=slip),
        *_call(3, "place", empty, location="Hall", position="floor"),
    ]
    assert moved_unseen(events) == {2} and classify(events)["affordance"] == 0
    looked = [*events[:5], *_call(3, "look_around", {"status": "success", "locations": []})]
    looked += _call(4, "place", empty, location="Hall", position="floor")
    assert classify(looked)["affordance"] == 1  # after a look, the empty hand is the agent's to know


def test_additional_steps_only_where_the_optimum_bounds_the_attempt() -> None:
    calm = row("m", "swap", 0, True, True, optimal=6)
    assert bounding_optimum(calm, []) == 6
    assert bounding_optimum(_with(calm, capabilities=["partial_observation"]), []) is None
    slip = PerturbationEvent(kind="slip", call=1, description="x", announced=True, object="mug")
    assert bounding_optimum(calm, [Perturbed(t=0.0, invocation=1, id="c", event=slip)]) is None


# --- capability validity ---------------------------------------------------------------------------


def test_capability_validity_sets_tagged_against_untagged() -> None:
    def attempt(model: str, i: int, ok: bool, tags: list[str]) -> AttemptRow:
        r = row(model, "memory", 0, ok, ok, instance=f"i{i}", task=f"i{i}")
        return _with(r, capabilities=tags, model_id=model)

    rows = [attempt("scripted/without-memory", i, i >= 4, ["memory"] if i < 5 else []) for i in range(10)]
    rows += [attempt("scripted/planner", i, True, ["memory"] if i < 5 else []) for i in range(10)]
    (v,) = capability_validity(rows)
    assert v.tag == "memory" and (v.tagged.successes, v.tagged.n) == (1, 5)
    assert (v.untagged.successes, v.untagged.n) == (5, 5) and v.fails_tagged and v.passes_untagged
    assert v.oracle_tagged is not None and v.oracle_tagged.rate == 1.0


def test_a_container_a_perturbation_closed_is_the_worlds_doing_only_where_it_is_the_cause() -> None:
    shut = PerturbationEvent(kind="close_container", call=2, description="x", announced=False, container="fridge")
    closed = {
        "status": "failure",
        "error": "out_of_reach",
        "message": "Inside the fridge, which is closed. open('fridge') first.",
    }
    empty = {"status": "failure", "error": "nothing_held", "message": "The robot holds nothing."}
    events = [
        *_call(1, "move_to", location="Kitchen"),
        Perturbed(t=1.6, invocation=1, id="c1", event=shut),
        *_call(2, "place", closed, location="Kitchen", position="inside"),
        *_call(3, "place", empty, location="Kitchen", position="shelf"),  # the agent's own error, shut or not
    ]
    counts = classify(events)
    assert moved_unseen(events) == {1} and counts["wrong_order"] == 0 and counts["affordance"] == 1
