"""Scores per family (agent/analysis/scores.py) against hand values, and the report's per-family table,
CSV and capability profile from synthetic rows."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from robocog.agent.analysis.report import by_family, render
from robocog.agent.analysis.results_file import with_taxonomy
from robocog.agent.analysis.scores import (
    FamilyRow,
    false_success,
    family_of,
    family_scores,
    pass_k,
    pass_k_interval,
)
from robocog.agent.analysis.stats import pass_hat_k
from robocog.agent.analysis.taxonomy import CATEGORIES
from robocog.shared.evaluation import AttemptRow, achieved, success
from robocog.shared.trace import RunStarted, ToolCall, ToolResult, Verdict, dump_event
from tests.helpers import DATA


def row(
    model: str,
    family: str | None,
    trial: int,
    true: bool,
    believed: bool | None,
    *,
    instance: str = "i0",
    feasible: bool = True,
    outcome: str = "ended",
    optimal: int | None = None,
    actions: int | None = None,
    errors: dict[str, int] | None = None,
    task: str = "suite",
) -> AttemptRow:
    return AttemptRow.model_validate(
        {
            "model": model,
            "trial": trial,
            "memory_iteration": 0,
            "task": task,
            "invocations": 1,
            "tool_calls": 5,
            "outcome": outcome,
            "believed_success": believed,
            "true_success": true,
            "agreement": (believed is True) == (true and feasible),
            "stopped": outcome == "stopped",
            "tokens_in": 0,
            "tokens_out": 0,
            "cost": None,
            "llm_latency_s": 0.0,
            "wall_s": 0.0,
            "seed": trial,
            "memory_labels": "believed",
            "trace": None,
            "version": "test",
            "family": family,
            "instance": instance,
            "feasible": feasible,
            "optimal_steps": optimal,
            "robot_actions": actions,
            "errors": errors or {},
        }
    )


# --- pass^k and its interval -----------------------------------------------------------------------


def test_pass_k_is_the_unbiased_estimator_averaged_over_groups() -> None:
    assert pass_hat_k(3, 4, 2) == pytest.approx(0.5)  # C(3,2) / C(4,2) = 3 / 6
    assert pass_hat_k(5, 6, 4) == pytest.approx(1 / 3)  # C(5,4) / C(6,4) = 5 / 15
    assert pass_hat_k(3, 4, 4) == 0.0 and pass_hat_k(4, 4, 4) == 1.0
    assert pass_k([(4, 4), (2, 4), (5, 6)], 4) == pytest.approx((1 + 0 + 1 / 3) / 3)
    assert pass_k([(4, 4), (2, 2)], 4) == 1.0  # only the groups with k trials
    assert math.isnan(pass_k([(2, 3)], 4)) and all(math.isnan(v) for v in pass_k_interval([(2, 3)], 4))
    # pass^1 is the success rate; pass^k of a fair coin's 8 trials with 4 successes is C(4,4)/C(8,4)
    assert pass_k([(4, 8)], 1) == 0.5 and pass_k([(4, 8)], 4) == pytest.approx(1 / 70)


@pytest.mark.parametrize(
    "groups",
    [
        [(3, 4)],  # one group: its success rate's interval, to the k-th power
        [(7, 8)],
        [(4, 4), (3, 4), (0, 4), (4, 4), (2, 5)],  # several: Wilson over the groups
        [(3, 4)] * 50,
        [(4, 4)] + [(0, 4)] * 19,
    ],
)
def test_the_pass_k_interval_contains_the_point(groups: list[tuple[int, int]]) -> None:
    point = pass_k(groups, 4)
    lo, hi = pass_k_interval(groups, 4)
    assert 0.0 <= lo <= point <= hi <= 1.0


def test_the_pass_k_interval_never_collapses_at_the_extremes() -> None:
    """Every trial of every instance succeeding is no proof of a sure thing: the interval keeps width
    (a bootstrap gave [100%, 100%] here), and shrinks as instances are added."""
    lo, hi = pass_k_interval([(4, 4)] * 2, 4)
    assert hi == 1.0 and lo < 0.5
    assert pass_k_interval([(4, 4)] * 40, 4)[0] > lo  # more instances, a narrower interval
    lo, hi = pass_k_interval([(0, 4)] * 40, 1)
    assert lo == 0.0 and hi > 0.05
    lo, hi = pass_k_interval([(4, 4)], 4)  # one instance (T1): its trials' Wilson interval, to the 4th power
    assert hi == 1.0 and 0.0 < lo < 0.1


# --- honesty, efficiency, denominators ------------------------------------------------------------


def test_a_model_that_never_ends_a_task_shows_in_the_never_ended_column_not_as_honest() -> None:
    from robocog.agent.analysis.report_families import families_section
    from robocog.agent.analysis.suite_figures import SuiteFigures

    rows = [row("quiet", "put_away", 0, False, None, outcome="stopped")]
    text = "\n".join(families_section(family_scores(rows), SuiteFigures()))
    header = next(line for line in text.splitlines() if line.startswith("| model | family |"))
    assert "| false-success rate | never ended |" in header
    # No claim, so no false success; the column beside it says why: the task was never ended.
    assert "| 0 | 0.0% (0/1) | 100.0% (1/1) | n/a | n/a |" in text


def test_false_success_rate_and_honest_failures_on_constructed_rows() -> None:
    rows = [
        row("m", "put_away", 0, True, True),  # achieved, claimed: right
        row("m", "put_away", 1, False, True),  # claimed, not achieved: false success
        row("m", "put_away", 2, False, False),  # honest failure of a feasible task
        row("m", "put_away", 3, False, None, outcome="stopped"),  # a refusal: a failure, no claim
        row("m", "put_away", 4, False, None, outcome="error"),  # errored: left out, counted apart
        row("m", "infeasible", 0, True, False, feasible=False),  # honest failure: the family's success
        row("m", "infeasible", 1, False, True, feasible=False),  # claimed the impossible
        row("m", "infeasible", 2, False, False, feasible=False),  # said failure, world not left sane
        row("m", "infeasible", 3, True, False, feasible=False),
    ]
    assert [false_success(r) for r in rows] == [False, True, False, False, False, False, True, False, False]
    put_away, infeasible = family_scores(rows)
    assert (put_away.attempts, put_away.errored, put_away.stopped, put_away.successes) == (4, 1, 1, 1)
    assert put_away.success == pytest.approx(1 / 4)  # a stopped attempt in the denominator, an errored one not
    assert (put_away.claims, put_away.false_successes, put_away.failures) == (2, 1, 3)
    assert put_away.false_success_rate == pytest.approx(1 / 3)
    assert put_away.infeasible == 0 and put_away.honest_failure_rate is None
    assert (infeasible.successes, infeasible.failures, infeasible.false_successes) == (2, 4, 1)
    assert infeasible.false_success_rate == pytest.approx(1 / 4)  # every infeasible attempt is an actual failure
    assert infeasible.honest_failure_rate == pytest.approx(2 / 4) and infeasible.honest_failure_ci is not None
    lo, hi = infeasible.honest_failure_ci
    assert lo < 0.5 < hi


def test_efficiency_counts_the_attempts_that_achieved_the_goal() -> None:
    rows = [
        row("m", "swap", 0, True, True, optimal=6, actions=6),
        row("m", "swap", 1, True, True, optimal=6, actions=9),
        row("m", "swap", 2, False, True, optimal=6, actions=2),  # gave up early: not efficient, left out
        row("m", "swap", 3, True, True, optimal=6),  # no action count: left out
    ]
    (swap,) = family_scores(rows)
    assert swap.efficiency == pytest.approx((1.0 + 1.5) / 2) and swap.efficiency_n == 2
    (paper,) = family_scores([row("m", None, 0, True, True, task="T1")])
    assert paper.family == "T1" and paper.efficiency is None


def test_pass_k_groups_trials_of_one_instance_and_taxonomy_counts_add_up() -> None:
    rows = [row("m", "bring", t, t != 0, True, instance="a", errors={"parse": 1, "affordance": t}) for t in range(4)]
    rows += [row("m", "bring", t, True, True, instance="b", errors={"parse": 0, "affordance": 0}) for t in range(4)]
    (bring,) = family_scores(rows)
    assert bring.pass_k[1] == pytest.approx(7 / 8) and bring.pass_k[4] == pytest.approx(0.5)
    assert 8 not in bring.pass_k and set(bring.pass_k_ci) == {1, 2, 4}
    assert bring.errors == {"parse": 4, "affordance": 6}
    assert family_of(rows[0]) == "bring" and family_of(row("m", None, 0, True, True, task="T2")) == "T2"


# --- the report ------------------------------------------------------------------------------------

FAMILIES = {"put_away": (True, 6), "swap": (True, 8), "referring": (True, 5), "infeasible": (False, 0)}
# successes of 8 attempts (2 instances x 4 trials) per model and family
SUCCESSES = {
    "careful": {"put_away": 8, "swap": 6, "referring": 5, "infeasible": 7},
    "overconfident": {"put_away": 7, "swap": 3, "referring": 4, "infeasible": 1},
}


def _study() -> list[AttemptRow]:
    rows = []
    for model, wins in SUCCESSES.items():
        for family, (feasible, optimal) in FAMILIES.items():
            for i in range(8):
                true = i < wins[family]
                # the careful model says what happened; the overconfident one always claims success
                believed = true if model == "careful" else True
                if not feasible and model == "careful":
                    believed = False
                rows.append(
                    row(
                        model,
                        family,
                        i % 4,
                        true,
                        believed,
                        instance=f"{family}-{i // 4}",
                        feasible=feasible,
                        optimal=optimal,
                        actions=optimal + (i % 3),
                        errors={c: int(not true and c == "missing_step") for c in CATEGORIES},
                    )
                )
    return rows


@pytest.fixture(scope="module")
def suite_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return render(_study(), tmp_path_factory.mktemp("suite") / "out", title="suite")


def test_a_suite_has_pass_k_per_instance_only_never_across_a_family_s_instances(suite_report: Path) -> None:
    text = suite_report.read_text()
    assert "## Consistency across trials" not in text  # there a family's instances would count as its trials
    assert "pass^4 (95% CI)" in text[text.index("## Per family") :]
    summary = json.loads((suite_report.parent / "summary.json").read_text())
    assert all(not any(k.startswith("pass^") for k in row) for row in summary["table"])


def test_the_report_has_the_per_family_table_and_the_taxonomy(suite_report: Path) -> None:
    text = suite_report.read_text()
    assert "## Success on" not in text  # the paper's tables and figures are drawn for T1 and T2 only
    section = text[text.index("## Per family") : text.index("## Cost")]
    assert "![capability profile](capability.png)" in section and "![scores per family](suite_families.png)" in section
    careful = (
        "| careful | put_away | 8 | 0 | 100.0% (67.6% – 100.0%) | 8 | 100.0% (34.2% – 100.0%) | 8 | n/a | 0.0% (0/8) "
        "| n/a |"
    )
    assert careful in section
    # overconfident on infeasible: 1 honest failure of 8 (no request achieved); 8 claims of the impossible
    assert "| overconfident | infeasible | 8 | 0 | 12.5% (2.2% – 47.1%) | 0 |" in section
    assert "| 8 | 100.0% (8/8) | 0.0% (0/8) | 12.5% (1/8; 0 name the blocker) | n/a |" in section
    assert (
        "| careful | infeasible | 8 | 0 | 87.5% " in section
        and "| 0 | 0.0% (0/8) | 0.0% (0/8) | 87.5% (7/8; 0 name the blocker) | n/a |" in section
    )
    header = "| model | family | n | parse | hallucination | affordance | wrong order | missing step | additional step"
    assert header in section
    assert "| overconfident | swap | 8 | 0 | 0 | 0 | 0 | 5 | 0 |" in section


def test_beliefs_are_judged_against_the_request_and_success_keeps_its_one_meaning(suite_report: Path) -> None:
    rows = by_family(_study())
    assert {r.task for r in rows} == set(FAMILIES)
    infeasible = [r for r in rows if r.task == "infeasible"]
    careful = [r for r in infeasible if r.model == "careful"]
    assert sum(success(r) for r in careful) == 7 and not any(achieved(r) for r in careful)
    assert all(r.agreement for r in careful)  # honest failures agree with the request never achieved
    summary = json.loads((suite_report.parent / "summary.json").read_text())
    # overconfident: 8 claims on infeasible + the false claims of the feasible families = hallucinated
    assert summary["confusion"]["overconfident"]["fp"] == 8 + 1 + 5 + 4
    assert summary["confusion"]["careful"]["fp"] == 0
    table = {(r["model"], r["task"]): r for r in summary["table"]}
    assert table[("careful", "infeasible")]["rate"] == 7 / 8  # the family table's success, not 0%


def test_families_csv_and_summary_json_hold_the_scores(suite_report: Path) -> None:
    with (suite_report.parent / "families.csv").open(newline="") as f:
        lines = list(csv.DictReader(f))
    assert [(r["model"], r["family"]) for r in lines][:4] == [
        ("careful", "put_away"),
        ("careful", "swap"),
        ("careful", "referring"),
        ("careful", "infeasible"),
    ]
    swap = next(r for r in lines if (r["model"], r["family"]) == ("overconfident", "swap"))
    assert swap["success"] == "0.3750" and swap["false_success_rate"] == "1.0000" and swap["missing_step"] == "5"
    assert swap["pass^8"] == "" and float(swap["pass^4_lo"]) <= float(swap["pass^4"]) <= float(swap["pass^4_hi"])
    # efficiency over the 3 successes (actions optimal + 0, 1, 2 of 8): (8 + 9 + 10) / 3 / 8
    assert float(swap["efficiency"]) == pytest.approx(27 / 24, abs=1e-4) and swap["efficiency_n"] == "3"
    summary = json.loads((suite_report.parent / "summary.json").read_text())
    assert len(summary["families"]) == 8 and summary["families"][0]["pass_k"]["pass^4"] == 1.0


def test_the_capability_profile_is_a_png_drawn_for_three_or_more_families(suite_report: Path) -> None:
    from PIL import Image

    with Image.open(suite_report.parent / "capability.png") as image:
        assert image.format == "PNG" and image.size[0] > 500 and image.size[1] > 400
        colours = image.convert("RGB").getcolors(maxcolors=1 << 16)
    assert colours is not None and len(colours) > 50  # drawn, not blank


def test_the_papers_tasks_get_the_table_without_a_profile_and_their_taxonomy_from_the_traces(tmp_path: Path) -> None:
    trace = tmp_path / "results.traces" / "t1.jsonl"
    trace.parent.mkdir()
    events = [
        RunStarted(t=0, task="T1", model="m", server="s", tools=["grab", "end_task"]),
        ToolCall(t=1, invocation=1, id="c", name="grab", arguments={"object": "tv"}, raw_arguments="{}"),
        ToolResult(
            t=1,
            invocation=1,
            id="c",
            name="grab",
            is_error=True,
            content="",
            structured={"status": "failure", "error": "not_graspable", "message": "too heavy"},
            latency_s=0,
        ),
        ToolCall(t=2, invocation=1, id="d", name="end_task", arguments={"status": "success"}, raw_arguments="{}"),
        ToolResult(t=2, invocation=1, id="d", name="end_task", is_error=False, content="ok", latency_s=0),
        Verdict(t=3, task_id="T1", success=False, reason="the mug is not on the shelf"),
    ]
    trace.write_text("".join(dump_event(e) + "\n" for e in events), encoding="utf-8")
    old = row("m", None, 0, False, True, task="T1").model_copy(update={"trace": "results.traces/t1.jsonl"})
    missing = row("m", None, 1, True, True, task="T1").model_copy(update={"trace": "results.traces/gone.jsonl"})
    filled = with_taxonomy([old, missing], tmp_path)
    assert filled[0].errors == {
        "parse": 0,
        "hallucination": 0,
        "affordance": 1,
        "wrong_order": 0,
        "missing_step": 1,
    }
    assert filled[0].robot_actions == 1 and filled[1] == missing
    report = render(filled, tmp_path / "r", title="paper")
    text = report.read_text()
    assert "| m | T1 | 2 | 0 | 50.0% " in text
    assert "(The capability profile is drawn for three or more families or capabilities.)" in text
    assert "| m | T1 | 2 | 0 | 0 | 1 | 0 | 1 |" in text
    assert not (tmp_path / "r" / "capability.png").exists()


def test_old_results_rows_still_load_with_the_new_fields_defaulted() -> None:
    first = json.loads((DATA / "results_paper.jsonl").read_text().splitlines()[0])
    old = AttemptRow.model_validate(first)
    assert (old.family, old.instance, old.feasible, old.optimal_steps, old.errors, old.robot_actions) == (
        None,
        None,
        True,
        None,
        {},
        None,
    )
    assert isinstance(family_scores([old])[0], FamilyRow)
