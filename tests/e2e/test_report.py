"""The report: statistics, the paper's figures beside ours, the errored attempts, the protocol and
the published CSV encoding, from committed results files checked by hand.

`data/results_paper.jsonl` (protocol `paper`, trials 0-1, memory iterations 0-2; T2 only after a
true T1 success):

- alpha: 6 T1 (one believed failure that truly succeeded, one hallucinated success) and 5 T2
  (two hallucinated successes, one stopped, one honest failure);
- beta: 2 of 6 T1 attempts and 1 of 4 T2 attempts errored (an UnsupportedParamsError, then a 500),
  one T2 stopped, every other attempt a believed true success;
- gamma: always believes success; T2 truly fails twice.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.agent.analysis.report import render
from robocog.agent.analysis.results_file import read_rows
from robocog.agent.analysis.stats import Summary, TableRow, by_protocol, shorten, summarise
from robocog.agent.analysis.tables_csv import upstream_task
from robocog.shared.evaluation import AttemptRow
from tests.helpers import DATA

PAPER = DATA / "results_paper.jsonl"
FIGURES = (
    "paper_fig3_confusion.png",
    "paper_fig4_success.png",
    "paper_fig5_tool_calls.png",
    "confusion.png",
    "memory_success.png",
    "memory_tool_calls.png",
)


@pytest.fixture(scope="module")
def rows() -> list[AttemptRow]:
    return read_rows(PAPER)


@pytest.fixture(scope="module")
def summary(rows: list[AttemptRow]) -> Summary:
    return summarise(rows)


@pytest.fixture(scope="module")
def report(rows: list[AttemptRow], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report with the upstream CSV, rendered once for the module."""
    return render(rows, tmp_path_factory.mktemp("report") / "out", title="paper", csv_format="upstream")


def _row(summary: Summary, model: str, task: str) -> TableRow:
    row = summary.row(model, task)
    assert row is not None, (model, task)
    return row


# --- the numbers ---------------------------------------------------------------------------------


def test_errored_attempts_are_counted_apart_and_left_out_of_every_statistic(summary: Summary) -> None:
    assert (summary.attempts, summary.counted, summary.errored_total) == (33, 30, 3)
    assert [(e.model, e.task, e.attempts, e.errored) for e in summary.errored] == [
        ("beta", "T1", 6, 2),
        ("beta", "T2", 4, 1),
    ]
    assert summary.errored[0].first_error.startswith("UnsupportedParamsError: litellm.UnsupportedParamsError")
    assert summary.errored[0].first_error.endswith("…") and len(summary.errored[0].first_error) == 90
    assert summary.errored[1].first_error == "InternalServerError: OpenAIException - upstream failure | status 500"

    beta_t1 = _row(summary, "beta", "T1")  # 4 counted, all true successes: 100%, not 4/6
    assert (beta_t1.executions, beta_t1.successes, beta_t1.rate, beta_t1.tool_calls) == (4, 4, 1.0, 17.5)
    assert [(p.memory_iteration, p.n) for p in beta_t1.by_memory_iteration] == [(0, 1), (1, 1), (2, 2)]
    assert beta_t1.pass_hat == {1: 1.0, 2: 1.0}  # pass^2 only where an iteration has two counted trials
    beta_t2 = _row(summary, "beta", "T2")  # 3 counted: a success, a stop, a success
    assert (beta_t2.executions, beta_t2.successes, beta_t2.stopped) == (3, 2, 1)
    assert beta_t2.tool_calls == pytest.approx((13 + 0 + 11) / 3)
    assert summary.confusion["beta"].grid == [[6, 0], [0, 1]]  # the stopped T2 as believed failure


def test_success_and_our_confusion_count_stopped_attempts_as_failures(summary: Summary) -> None:
    alpha_t1, alpha_t2 = _row(summary, "alpha", "T1"), _row(summary, "alpha", "T2")
    assert (alpha_t1.executions, alpha_t1.successes, alpha_t1.believed) == (6, 5, 5)
    assert (alpha_t2.executions, alpha_t2.successes, alpha_t2.stopped) == (5, 1, 1)
    assert alpha_t2.rate == 0.2
    c = summary.confusion["alpha"]
    assert (c.tp, c.fp, c.fn, c.tn) == (5, 3, 1, 2)
    assert _row(summary, "gamma", "T2").successes == 4


def test_the_papers_confusion_is_row_normalised_without_stopped_or_errored_attempts(summary: Summary) -> None:
    alpha = summary.paper_confusion["alpha"]  # rows actual failure/success, columns believed failure/success
    assert alpha.counts == ((1, 3), (1, 5)) and alpha.n == 10  # the stopped T2 is not there
    assert alpha.shares[0] == (0.25, 0.75)
    assert alpha.shares[1] == pytest.approx((1 / 6, 5 / 6))
    beta = summary.paper_confusion["beta"]  # never truly failed once stopped and errored are out
    assert beta.counts == ((0, 0), (0, 6)) and beta.shares == ((None, None), (0.0, 1.0))
    gamma = summary.paper_confusion["gamma"]
    assert gamma.counts == ((0, 2), (0, 10)) and gamma.shares == ((0.0, 1.0), (0.0, 1.0))


def test_the_memory_points_feed_the_papers_bars_and_boxes(summary: Summary) -> None:
    alpha_t2 = _row(summary, "alpha", "T2")
    # Fig. 4: the stopped attempt at iteration 2 counts as a failure.
    assert [(p.memory_iteration, p.n, p.rate, p.stopped) for p in alpha_t2.by_memory_iteration] == [
        (0, 2, 0.0, 0),
        (1, 1, 1.0, 0),
        (2, 2, 0.0, 1),
    ]
    # Fig. 5: only attempts that ended.
    assert [p.ended_tool_calls for p in alpha_t2.by_memory_iteration] == [(14, 10), (12,), (9,)]
    beta_t2 = _row(summary, "beta", "T2")
    assert [p.ended_tool_calls for p in beta_t2.by_memory_iteration] == [(13,), (), (11,)]
    assert summary.memory_iterations == (0, 1, 2)


def test_tool_call_intervals_never_go_below_zero(summary: Summary) -> None:
    last = _row(summary, "alpha", "T2").by_memory_iteration[2]  # 3 and 9 calls: mean 6, t half-width 38.1
    assert last.tool_calls == 6.0
    assert last.tool_calls_ci[0] == 0.0
    assert last.tool_calls_ci[1] == pytest.approx(6 + 12.706 * 18**0.5 / 2**0.5, abs=1e-3)
    for row in summary.table:
        for p in row.by_memory_iteration:
            one = p.n == 1 and all(math.isnan(v) for v in p.tool_calls_ci)  # no interval from one value
            assert one or p.tool_calls_ci[0] >= 0.0
            assert 0.0 <= p.rate_ci[0] <= p.rate_ci[1] <= 1.0


def test_shorten_keeps_the_first_line_within_the_limit() -> None:
    assert shorten("ValueError: bad\nTraceback ...") == "ValueError: bad"
    assert shorten("x" * 200, limit=10) == "xxxxxxxxx…"
    assert shorten("") == ""


# --- the report's files --------------------------------------------------------------------------


def test_every_figure_is_written_and_embedded(report: Path) -> None:
    text = report.read_text()
    for name in FIGURES:
        data = (report.parent / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 10_000, name
        assert f"]({name})" in text, name


def test_report_md_states_the_protocol_and_the_errored_attempts_first(report: Path) -> None:
    text = report.read_text()
    assert "**Protocol: `paper`** — the paper's protocol exactly" in text
    errored = text.index("## Errored attempts")
    assert errored < text.index("## Success on T1")
    assert "3 of 33 attempts errored" in text
    assert "| beta | T1 | 6 | 2 | `UnsupportedParamsError: litellm.UnsupportedParamsError: anthropic" in text
    assert "| beta | T2 | 4 | 1 | `InternalServerError: OpenAIException - upstream failure \\| status 500` |" in text
    assert "33 attempts (30 counted, 3 errored); models: alpha, beta, gamma; tasks: T1, T2." in text
    assert "| beta | 4 | 100.0% | 51.0% – 100.0% | 4 | 100.0% | 0 |" in text  # T1 without the errored two
    assert "| alpha | 5 | 20.0% | 3.6% – 62.4% | 3 | 60.0% | 1 |" in text
    # The paper's Fig. 3 as a table: row percentages with counts; an empty row is n/a.
    assert "| alpha | 10 | 25.0% (1) | 75.0% (3) | 16.7% (1) | 83.3% (5) |" in text
    assert "| beta | 6 | n/a (0) | n/a (0) | 0.0% (0) | 100.0% (6) |" in text
    assert "| alpha | 5 | 3 | 1 | 2 |" in text  # our counts
    assert "| alpha | T2 | 2 | 2 | 1 | 0.0% (0.0% – 65.8%) | 6.0 (0.0 – 44.1) |" in text
    assert "in the published implementation's encoding" in text


def test_summary_json_carries_the_errored_counts_and_the_papers_confusion(report: Path) -> None:
    summary = json.loads((report.parent / "summary.json").read_text())
    assert (summary["attempts"], summary["counted"], summary["errored_total"]) == (33, 30, 3)
    assert summary["protocols"] == {"paper": 33}
    assert [(e["model"], e["task"], e["errored"]) for e in summary["errored"]] == [("beta", "T1", 2), ("beta", "T2", 1)]
    assert summary["paper_confusion"]["alpha"]["counts"] == [[1, 3], [1, 5]]
    assert summary["paper_confusion"]["beta"]["row_shares"] == [[None, None], [0.0, 1.0]]
    assert summary["confusion"]["alpha"] == {"tp": 5, "fp": 3, "fn": 1, "tn": 2}


def test_the_upstream_csv_has_the_published_encoding_without_errored_attempts(report: Path) -> None:
    text = (report.parent / "results.csv").read_text()
    lines = text.splitlines()
    assert lines[:4] == [
        "Model,Memory,Task,Trial,Invokes,Toolcalls,Belief,Truth,Accuracy,Stopped",
        "alpha,0,1,1,1,20,1,1,1,0",
        "alpha,0,2,1,1,14,1,0,0,0",  # a hallucinated success
        "alpha,1,1,1,2,18,1,1,1,0",
    ]
    assert "alpha,2,2,1,10,3,0,0,1,1" in lines  # stopped: belief 0, so it agrees with a failure
    assert "alpha,0,1,2,1,22,0,1,0,0" in lines  # trial 1 is Trial 2; believed failure, true success
    assert "beta,1,2,2,10,0,0,0,1,1" in lines  # a stop with no tool call at all
    assert len(lines) == 1 + 30  # the three errored attempts are left out
    with (report.parent / "results.csv").open() as f:
        table = list(csv.DictReader(f))
    assert {r["Task"] for r in table} == {"1", "2"}
    assert {r["Trial"] for r in table} == {"1", "2"} and {r["Memory"] for r in table} == {"0", "1", "2"}
    assert all(r[k] in {"0", "1"} for r in table for k in ("Belief", "Truth", "Accuracy", "Stopped"))
    assert [r["Model"] for r in table].count("beta") == 7


def test_upstream_task_numbers_t1_and_t2_and_keeps_other_ids() -> None:
    assert [upstream_task(t) for t in ("T1", "T2", "T3", "fetch_mug")] == ["1", "2", "T3", "fetch_mug"]


def test_our_csv_stays_the_default_with_every_attempt_that_counts(rows: list[AttemptRow], tmp_path: Path) -> None:
    out = render(rows, tmp_path / "r").parent
    lines = (out / "results.csv").read_text().splitlines()
    assert len(lines) == 1 + 30  # the one policy: the three errored attempts are left out here too
    assert "beta,1,T1,0,0,0,False,False,False,False,False,True" not in lines


def test_an_old_file_without_outcome_or_protocol_has_no_errors_and_is_robocog(tmp_path: Path) -> None:
    report = render(read_rows(DATA / "results_small.jsonl"), tmp_path / "r", title="small")
    text = report.read_text()
    assert "**Protocol: `robocog`**" in text
    assert "No attempt errored: every attempt counts." in text and "## Errored attempts" not in text
    assert json.loads((report.parent / "summary.json").read_text())["errored_total"] == 0


def test_mixed_protocols_are_reported_side_by_side(rows: list[AttemptRow], tmp_path: Path) -> None:
    ours = [r.model_copy(update={"protocol": "robocog"}) for r in rows if r.model == "gamma"]
    mixed = by_protocol(rows + ours)
    assert {r.model for r in mixed} == {"alpha (paper)", "beta (paper)", "gamma (paper)", "gamma (robocog)"}
    assert by_protocol(rows) == rows
    report = render(rows + ours, tmp_path / "r", title="mixed")
    text = report.read_text()
    assert "**Protocols: mixed** — `paper` (33 attempts), `robocog` (12 attempts)." in text
    assert "| gamma (robocog) | 12 | 0.0% (0) | 100.0% (2) | 0.0% (0) | 100.0% (10) |" in text


def test_a_study_where_every_attempt_errored_still_reports_the_errors(rows: list[AttemptRow], tmp_path: Path) -> None:
    errored = [r for r in rows if r.outcome == "error"]
    report = render(errored, tmp_path / "r", title="down")
    text = report.read_text()
    assert "3 of 3 attempts errored" in text and "Every attempt errored: there is nothing to measure." in text
    assert not list(report.parent.glob("*.png"))


def test_robocog_report_csv_upstream(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robocog.agent.cli", "report", str(PAPER), "--out", str(tmp_path), "--csv", "upstream"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "results.csv").read_text().splitlines()[1] == "alpha,0,1,1,1,20,1,1,1,0"
    bad = subprocess.run(
        [sys.executable, "-m", "robocog.agent.cli", "report", str(PAPER), "--out", str(tmp_path), "--csv", "theirs"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode == 2 and "invalid choice" in bad.stderr


def test_report_warns_when_the_rows_of_a_file_disagree_on_their_provenance(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from robocog.agent.cli.main import main
    from tests.unit.test_provenance import rows as provenanced

    mixed = provenanced()
    mixed[0] = mixed[0].model_copy(update={"version": "9.9.9"})
    results = tmp_path / "mixed.jsonl"
    results.write_text("".join(r.model_dump_json() + "\n" for r in mixed))
    assert main(["report", str(results), "--out", str(tmp_path / "out")]) == 0
    warned = capsys.readouterr().err.splitlines()
    assert warned == [
        f"robocog: warning: {results}: rows disagree on the robocog version: "
        f"0.1.0 ({len(mixed) - 1} rows), 9.9.9 (1 rows)"
    ]
    text = (tmp_path / "out" / "report.md").read_text()
    assert "## Provenance: the rows disagree" in text and "9.9.9 (1 rows)" in text
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert len(summary["provenance_disagreements"]) == 1

    agreeing = tmp_path / "agreeing.jsonl"
    agreeing.write_text("".join(r.model_dump_json() + "\n" for r in provenanced()))
    assert main(["report", str(agreeing), "--out", str(tmp_path / "out2")]) == 0
    assert capsys.readouterr().err == ""
    assert "Provenance" not in (tmp_path / "out2" / "report.md").read_text()


HOSTILE_LABELS = ("<script>alert(1)</script>", "[click](javascript:alert(1))", "<img src=x onerror=alert(1)>", "a|b")


@pytest.mark.parametrize("label", HOSTILE_LABELS)
def test_a_model_label_reaches_report_md_as_words_never_as_html_or_a_link(
    rows: list[AttemptRow], tmp_path: Path, label: str
) -> None:
    """report.md is read by any Markdown renderer, some of which run raw HTML: a label (anyone's words)
    is escaped, so rendered with HTML allowed it is still only text."""
    from markdown_it import MarkdownIt

    hostile = [r.model_copy(update={"model": label}) for r in rows]
    text = render(hostile, tmp_path / "r", title="hostile").read_text(encoding="utf-8")
    html = MarkdownIt("commonmark", {"html": True}).enable("table").render(text)
    for bad in ("<script", "<img src=x", 'href="javascript:'):  # tags and links, not the words
        assert bad not in html.lower(), (label, bad)
    assert label.replace("|", "\\|") not in text or "|" in label  # never verbatim (the bar is escaped)
    visible = MarkdownIt("commonmark", {"html": False}).enable("table").render(text)
    assert label.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;") in visible  # shown as written
