"""The leaderboard's entries from synthetic rows (agent/analysis/leaderboard.py): one per model and
protocol, pooled over studies, scored by `family_row`, capability columns only when rows carry tags,
the verified mark from provenance, traces and replay, a study given twice refused, and the plot drawn for
entries at the edges (success 0 and 1, cost unknown)."""

from __future__ import annotations

from pathlib import Path

import pytest

from robocog.agent.analysis.leaderboard import Study, board, board_json, board_markdown, draw_success_cost
from robocog.agent.analysis.scores import family_row
from robocog.shared.evaluation import AttemptRow
from tests.unit.test_provenance import shipped


def row(model: str, trial: int, true: bool, **change: object) -> AttemptRow:
    fields: dict[str, object] = {
        "model": model,
        "trial": trial,
        "memory_iteration": 0,
        "task": "T1",
        "invocations": 1,
        "tool_calls": 12,
        "outcome": "ended",
        "believed_success": True,
        "true_success": true,
        "agreement": true,
        "stopped": False,
        "tokens_in": 100,
        "tokens_out": 10,
        "cost": None,
        "llm_latency_s": 0.1,
        "wall_s": 1.0,
        "seed": trial,
        "memory_labels": "believed",
        "trace": None,
        "version": "1.0",
        "study": "s",
        "model_id": f"scripted/{model}",
        "provenance": shipped("T1"),
    }
    return AttemptRow.model_validate({**fields, **change})


def study(name: str, rows: list[AttemptRow], traced: bool = True, replay: str | None = "matches") -> Study:
    """A study whose rows were replayed (`replay`: each row's status; None: no replay record)."""
    return Study(name, tuple(rows), tuple(traced for _ in rows), None if replay is None else (replay,) * len(rows))


def test_entries_pool_a_model_over_studies_and_score_it_with_family_row() -> None:
    a = [row("m", t, t % 2 == 0, cost=0.01) for t in range(4)]
    b = [row("m", t, True, study="other", cost=None) for t in range(4)]
    paper = [row("m", t, False, protocol="paper", study="p") for t in range(2)]
    result = board([study("a.jsonl", a), study("b.jsonl", b), study("p.jsonl", paper)])
    assert [e.name for e in result.entries] == ["m (robocog)", "m (paper)"]
    pooled = result.entries[0]
    reference = family_row("m", "all", a + b)
    assert (pooled.overall.success, pooled.overall.success_ci) == (reference.success, reference.success_ci)
    assert pooled.overall.pass_k == reference.pass_k and pooled.studies == ("a.jsonl", "b.jsonl")
    assert pooled.cost_per_attempt == pytest.approx(0.01) and pooled.cost_known == 4  # unknown costs left out
    assert pooled.tokens_per_attempt == 110
    assert result.entries[1].cost_per_attempt is None
    assert result.capabilities == () and set(board_json(result)["entries"][0]["families"]) == {"T1"}


def test_capability_columns_appear_only_for_tagged_rows() -> None:
    tagged = [row("m", t, t < 3, capabilities=["navigation", "memory"] if t < 2 else ["navigation"]) for t in range(4)]
    result = board([study("t.jsonl", tagged), study("u.jsonl", [row("n", 0, True, study="u")])])
    assert result.capabilities == ("memory", "navigation")
    m = next(e for e in result.entries if e.model == "m")
    assert (m.capabilities["navigation"].attempts, m.capabilities["navigation"].success) == (4, 0.75)
    assert (m.capabilities["memory"].attempts, m.capabilities["memory"].success) == (2, 1.0)
    assert next(e for e in result.entries if e.model == "n").capabilities == {}
    text = board_markdown(result)
    assert "| cap. memory | cap. navigation |" in text


def test_verified_needs_shipped_provenance_every_trace_and_a_replay_that_matches() -> None:
    good = [row("m", t, True) for t in range(2)]
    untraced = [row("n", t, True, study="n") for t in range(2)]
    old = [row("o", t, True, study="o", provenance=None) for t in range(2)]
    unreplayed = [row("u", t, True, study="u") for t in range(2)]
    forged = [row("f", t, True, study="f") for t in range(2)]
    errored = [row("e", 0, False, study="e", outcome="error", agreement=None), row("e", 1, True, study="e")]
    replays = {"errored": ("skipped", "matches")}
    result = board(
        [
            study("g", good),
            study("n", untraced, traced=False, replay="missing"),
            study("o", old),
            study("u", unreplayed, replay=None),
            study("f", forged, replay="differs"),
            Study("errored", tuple(errored), (True, True), replays["errored"]),
        ]
    )
    marks = {e.model: e.verification.problems for e in result.entries}
    assert marks == {
        "m": (),
        "n": ("trace missing (2 rows)", "not replayed (2 rows)"),
        "o": ("no provenance (2 rows)",),
        "u": ("not replayed (2 rows)",),
        "f": ("replay differs (2 rows)",),
        "e": (),  # an errored attempt has nothing to replay
    }
    replayed = {e.model: (e.replayed, e.replayable) for e in result.entries}
    assert replayed == {"m": (2, 2), "n": (0, 2), "o": (2, 2), "u": (0, 2), "f": (2, 2), "e": (1, 1)}
    text = board_markdown(result)
    assert "- n (robocog): trace missing (2 rows); not replayed (2 rows)" in text
    assert "| f | robocog | no (2 of 2 replayed) |" in text and "| m | robocog | yes (2 of 2 replayed) |" in text


def test_the_same_attempts_twice_are_refused() -> None:
    rows = [row("m", 0, True)]
    with pytest.raises(ValueError, match=r"a\.jsonl and a\.json hold the same attempts"):
        board([study("a.jsonl", rows), study("a.json", rows)])


def test_the_plot_draws_entries_at_the_edges(tmp_path: Path) -> None:
    perfect = [row("p", t, True, cost=0.002) for t in range(80)]  # an interval whose top rounds below 1
    nothing = [row("z", t, False, study="z") for t in range(3)]
    result = board([study("p", perfect), study("z", nothing)])
    assert draw_success_cost(result, tmp_path) == "success_cost.png"
    assert (tmp_path / "success_cost.png").stat().st_size > 10_000


def test_every_number_is_rounded_once_and_the_page_shows_the_markdown_s_digits() -> None:
    """86/132 is 65.1515…%: 65.2% in leaderboard.md and in what the page shows (`shown`), never 65.1%
    from the JSON's 0.6515 rounded again; each interval's bounds likewise, from the unrounded bound."""
    rows = [row("m", i % 2, i < 86, memory_iteration=i // 2, seed=i % 2) for i in range(132)]
    b = board([study("s", rows)])
    (entry,) = board_json(b)["entries"]
    low, high = b.entries[0].overall.success_ci
    assert entry["shown"]["success"] == "65.2%" and entry["success"] == 0.6515
    assert entry["shown"]["success_ci"] == f"[{100 * low:.1f}%, {100 * high:.1f}%]"
    line = next(line for line in board_markdown(b).splitlines() if line.startswith("| 1 |"))
    assert f"| {entry['shown']['success']} {entry['shown']['success_ci']} |" in line
    for k, text in entry["shown"]["pass_k"].items():
        assert f"{text} {entry['shown']['pass_k_ci'][k]}" in line


def test_attempts_that_never_ended_are_counted_in_the_json_the_markdown_and_what_the_page_shows() -> None:
    never = {"outcome": "stopped", "believed_success": None, "agreement": None, "stopped": True}
    rows = [row("m", t, False, **never) for t in range(3)] + [row("m", t, True) for t in range(3, 8)]
    b = board([study("s", rows)])
    (entry,) = board_json(b)["entries"]
    assert entry["never_ended"] == 3 and entry["shown"]["never_ended"] == "3" and entry["attempts"] == 8
    table = {
        line.split("|")[1].strip(): [c.strip() for c in line.split("|")]
        for line in board_markdown(b).splitlines()
        if line.startswith("| ")
    }
    assert table["1"][table["#"].index("never ended")] == "3"
