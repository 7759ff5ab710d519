"""Fresh splits' names and groups (robocog.shared.seeded_splits, the leaderboard): SPLIT@SEED with a
bounded decimal seed, refused in one line otherwise; a study's config refuses a bad one before
anything is generated; the leaderboard keeps each fresh split (suite, split, seed) apart, and the
shipped splits pooled as before."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from robocog.agent.analysis.leaderboard import board, board_json, board_markdown
from robocog.agent.analysis.submission import load_study
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import AttemptRow, EvalConfig
from robocog.shared.seeded_splits import MAX_SEED, parse_split, split_text
from tests.unit.test_leaderboard_board import row, study
from tests.unit.test_provenance import shipped


def test_a_split_is_a_name_or_a_name_at_a_bounded_seed() -> None:
    assert parse_split("test") == ("test", None)
    assert parse_split("test@12345") == ("test", 12345)
    assert parse_split(f"dev@{MAX_SEED}") == ("dev", MAX_SEED)
    assert split_text("test", 7) == "test@7" and split_text("test", None) == "test"
    for hostile in ("test@", "@5", "test@-1", "test@1e5", "test@0x10", f"test@{MAX_SEED + 1}", "a/b@1", "t@1@2"):
        with pytest.raises(ConfigError) as caught:
            parse_split(hostile)
        assert "\n" not in str(caught.value) and "SPLIT@SEED" in str(caught.value)
    with pytest.raises(ConfigError):
        parse_split(12345)


def test_a_study_refuses_a_bad_seed_before_generating() -> None:
    with pytest.raises(ValidationError) as caught:
        EvalConfig.model_validate({"models": [{"model": "scripted/planner"}], "split": "test@99999999999"})
    assert caught.value.errors()[0]["loc"] == ("split",)


#: A suite robocog does not ship: the board groups its rows by split without generating any (a shipped
#: suite's fresh split is generated to check the rows against it: minutes for robocog-v2.1's test split
#: on a machine whose cache is empty, as CI's is).
SUITE = "house-of-mine"


def _fresh(model: str, trial: int, seed: int | None) -> AttemptRow:
    provenance = shipped("T1").model_copy(update={"suite": SUITE, "split": "test", "split_seed": seed})
    return row(model, trial, True, provenance=provenance, study=f"s{seed}")


def test_the_leaderboard_keeps_fresh_splits_apart_and_the_shipped_ones_pooled() -> None:
    a = [_fresh("m", t, 12345) for t in range(2)]
    b = [_fresh("m", t, 777) for t in range(3)]
    shipped_rows = [_fresh("m", t, None) for t in range(4)]
    result = board([study("a", a), study("b", b), study("c", shipped_rows)])
    got = [(e.split, e.overall.attempts) for e in result.entries]
    assert got == [
        ((SUITE, "test", 12345), 2),
        ((SUITE, "test", 777), 3),
        ((None, None, None), 4),
    ]
    assert [e["seed"] for e in board_json(result)["entries"]] == [12345, 777, None]
    text = board_markdown(result)
    assert "| split |" in text and f"| {SUITE} / test@777 |" in text and "| shipped |" in text
    plain = board([study("c", shipped_rows)])
    assert "| split |" not in board_markdown(plain) and board_json(plain)["fresh_splits"] is False


def test_a_results_file_of_many_fresh_splits_is_refused_before_any_is_generated(tmp_path: Path) -> None:
    rows = [_fresh("m", t, seed) for t, seed in enumerate((1, 2, 3))]
    path = tmp_path / "many.jsonl"
    path.write_text("".join(r.model_dump_json() + "\n" for r in rows))
    with pytest.raises(ValueError, match="its rows ran on 3 fresh splits; a study runs on one"):
        load_study(path)
