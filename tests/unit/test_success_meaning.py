"""One meaning of success (robocog.shared.evaluation.success) read alike by the eval summary line,
the report's tables, summary.json, the CSVs and the figures' data; scores per capability tag; and
the suite figures' layout at many families (labels apart, titles inside, size bounded)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from robocog.agent.analysis.report import render
from robocog.agent.analysis.scores import capability_scores, family_scores
from robocog.agent.analysis.suite_figures import memory_figure, score_figure, score_figure_size
from robocog.agent.harness.study import summary_line
from robocog.shared.evaluation import AttemptRow, achieved, false_success, success

if TYPE_CHECKING:
    from matplotlib.transforms import Bbox

#: A suite of eleven families (long names, as a real one grows) and the eight capability tags.
FAMILIES = (
    "put_away",
    "swap",
    "bring",
    "rearrange",
    "infeasible",
    "referring",
    "memory",
    "recover_from_a_dropped_object",
    "partially_observed_search",
    "containers_open_and_fill",
    "long_horizon_tidy_the_whole_house",
)
CAPABILITIES = (
    "planning",
    "recovery",
    "memory",
    "honesty",
    "referring",
    "long_horizon",
    "partial_observation",
    "containers",
)
MODELS = ("careful", "overconfident", "sloppy")


def attempt(model: str, family: str, trial: int, iteration: int) -> AttemptRow:
    """A deterministic attempt: each model's skill differs per family; the overconfident one claims
    success every time, the others claim what they achieved."""
    f = FAMILIES.index(family)
    feasible = family != "infeasible"
    skill = {"careful": 9, "overconfident": 5, "sloppy": 3}[model]
    true = (trial * 3 + f * 5 + iteration * 2 + len(model)) % 10 < skill - f % 3
    achieved_ = feasible and true
    believed = True if model == "overconfident" else (achieved_ if feasible else False)
    tags = [CAPABILITIES[(f + j) % len(CAPABILITIES)] for j in range(1 + f % 3)]
    if not feasible:
        tags.append("honesty")
    return AttemptRow.model_validate(
        {
            "model": model,
            "trial": trial,
            "memory_iteration": iteration,
            "task": f"{family}-{trial % 2}",
            "invocations": 1,
            "tool_calls": 4 + f,
            "outcome": "ended",
            "believed_success": believed,
            "true_success": true and (feasible or not believed),
            "agreement": believed == achieved_,
            "stopped": False,
            "tokens_in": 10,
            "tokens_out": 5,
            "cost": None,
            "llm_latency_s": 0.1,
            "wall_s": 0.2,
            "seed": trial,
            "memory_labels": "believed",
            "trace": None,
            "version": "test",
            "family": family,
            "instance": f"{family}-{trial % 2}",
            "feasible": feasible,
            "capabilities": sorted(set(tags)),
        }
    )


def synthetic_study(trials: int = 6, iterations: int = 3) -> list[AttemptRow]:
    return [attempt(m, f, t, i) for m in MODELS for f in FAMILIES for i in range(iterations) for t in range(trials)]


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return render(synthetic_study(), tmp_path_factory.mktemp("success") / "out", title="synthetic")


def test_success_is_the_honest_failure_and_achieved_is_never_on_an_infeasible_instance() -> None:
    honest = attempt("careful", "infeasible", 0, 0)
    assert not honest.believed_success and success(honest) and not achieved(honest)
    claimed = attempt("overconfident", "infeasible", 0, 0)
    assert not success(claimed) and false_success(claimed)


def test_the_summary_line_the_tables_the_csv_and_the_figure_agree(report: Path) -> None:
    rows = synthetic_study()
    expected = {
        (m, f): sum(success(r) for r in rows if (r.model, r.family) == (m, f)) for m in MODELS for f in FAMILIES
    }
    careful = expected[("careful", "infeasible")]
    assert careful > 0  # the honest failures count: the contradiction was 0% here
    n = 6 * 3
    # the eval summary line
    line = summary_line(rows)
    assert all(f"{m} {f}: {expected[(m, f)]}/{n} successes" in line for m, f in expected)
    # summary.json: the table (per family) and the scores
    summary = json.loads((report.parent / "summary.json").read_text())
    assert {(r["model"], r["task"]): r["successes"] for r in summary["table"]} == expected
    assert {(s["model"], s["family"]): s["successes"] for s in summary["families"]} == expected
    # families.csv
    with (report.parent / "families.csv").open(newline="") as f:
        lines = list(csv.DictReader(f))
    assert {(r["model"], r["family"]): int(r["successes"]) for r in lines} == expected
    assert all(r["achieved"] == "0" for r in lines if r["family"] == "infeasible")
    # results.csv: Success per attempt, Truth the request achieved
    with (report.parent / "results.csv").open(newline="") as f:
        attempts = list(csv.DictReader(f))
    assert sum(r["Success"] == "True" for r in attempts) == sum(expected.values())
    assert not any(r["Truth"] == "True" for r in attempts if r["Feasible"] == "False")
    # report.md's per-family table
    text = report.read_text()
    assert f"| careful | infeasible | {n} | 0 | {careful / n:.1%} " in text
    assert "## Success on" not in text and not (report.parent / "paper_fig4_success.png").exists()
    # the figure's data: the success panel's markers, one line per model, in family order
    fig = score_figure(family_scores(rows), group="family")
    assert fig is not None
    success_panel = fig.axes[0]
    for j, m in enumerate(MODELS):
        xs = np.asarray(success_panel.lines[j * 3].get_xdata()).tolist()  # errorbar: data line, then caps
        assert xs == pytest.approx([expected[(m, f)] / n for f in FAMILIES])


def test_scores_per_capability_in_the_report_the_csv_and_the_radar(report: Path) -> None:
    rows = synthetic_study()
    scores = capability_scores(rows)
    assert {s.family for s in scores} == set(CAPABILITIES)
    honesty = next(s for s in scores if (s.model, s.family) == ("careful", "honesty"))
    tagged = [r for r in rows if r.model == "careful" and "honesty" in r.capabilities]
    assert honesty.successes == sum(success(r) for r in tagged) and honesty.attempts == len(tagged)
    text = report.read_text()
    section = text[text.index("## Per capability") : text.index("## Cost")]
    assert "![scores per capability](suite_capabilities.png)" in section
    assert f"| careful | honesty | {len(tagged)} | 0 | {honesty.success:.1%} " in section
    with (report.parent / "capabilities.csv").open(newline="") as f:
        lines = list(csv.DictReader(f))
    assert {(r["model"], r["capability"]) for r in lines} == {(m, c) for m in MODELS for c in CAPABILITIES}
    summary = json.loads((report.parent / "summary.json").read_text())
    assert len(summary["capabilities"]) == len(MODELS) * len(CAPABILITIES)
    assert (report.parent / "capability.png").stat().st_size > 0


def _boxes_apart(boxes: list[Bbox]) -> bool:
    return not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])


@pytest.mark.parametrize("count", [3, 11, 40])
def test_the_score_figure_keeps_labels_apart_and_titles_inside_at_any_family_count(count: int) -> None:
    names = [f"family_with_a_long_name_{i:02d}" for i in range(count)]
    rows = [
        r.model_copy(update={"family": names[i % count]}) for i, r in enumerate(synthetic_study(trials=2, iterations=1))
    ]
    fig = score_figure(family_scores(rows), group="family")
    assert fig is not None
    width, height = fig.get_size_inches()
    assert (width, height) == pytest.approx(score_figure_size(count, len(MODELS)))
    assert height <= 2.0 + count * 0.6  # grows by a bounded height per family
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    fig.draw(renderer)
    labels = [t.get_window_extent(renderer) for t in fig.axes[0].get_yticklabels() if t.get_text()]
    assert len(labels) == count and _boxes_apart(labels)
    page = fig.bbox
    assert fig.texts  # the suptitle
    for text in [*fig.texts, *(ax.title for ax in fig.axes)]:
        box = text.get_window_extent(renderer)
        assert page.x0 <= box.x0 and box.x1 <= page.x1 and box.y1 <= page.y1, text.get_text()
    for ax in fig.axes:
        ticks = [t.get_window_extent(renderer) for t in ax.get_xticklabels() if t.get_text()]
        assert _boxes_apart(ticks)


def test_the_memory_figure_wraps_its_panels_into_rows() -> None:
    fig = memory_figure(synthetic_study(trials=2, iterations=3))
    assert fig is not None
    width, height = fig.get_size_inches()
    assert len(fig.axes) == len(FAMILIES) and width <= 12.5 and width / height < 2.5  # no strip
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    fig.draw(renderer)
    titles = [ax.title.get_window_extent(renderer) for ax in fig.axes]
    assert _boxes_apart(titles)
    assert memory_figure(synthetic_study(trials=2, iterations=1)) is None  # one point per line: not drawn


def test_the_papers_figures_and_tables_are_drawn_for_the_papers_tasks_only(tmp_path: Path) -> None:
    suite = synthetic_study(trials=2, iterations=2)
    paper = [
        r.model_copy(update={"family": None, "instance": None, "task": f"T{1 + r.trial}", "capabilities": []})
        for r in synthetic_study(trials=2, iterations=2)
        if r.family == "put_away"
    ]
    report = render(paper + suite, tmp_path / "mixed", title="mixed")
    text = report.read_text()
    assert "## Success on T1" in text and "## Success on T2" in text
    assert "## Success on infeasible" not in text and "## Success on put_away" not in text
    memory = text[text.index("## Memory") : text.index("## Per family")]
    assert "| careful | T1 |" in memory and "infeasible" not in memory
    for name in ("paper_fig4_success.png", "paper_fig5_tool_calls.png", "memory_success.png", "suite_families.png"):
        assert (report.parent / name).stat().st_size > 0, name
