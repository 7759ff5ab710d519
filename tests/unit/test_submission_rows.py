"""A submission of a suite whose instances have earlier tasks (robocog-v2.1's memory family): an
earlier task's row is no trial of its instance, and an instance not run has no trace to miss."""

from __future__ import annotations

from robocog.agent.analysis.submission import Submission, _groups
from robocog.shared.evaluation import AttemptRow
from tests.unit.test_leaderboard_board import row


def _instance_rows() -> list[AttemptRow]:
    earlier = row("m", 0, True, task="dev-memory-000-pre1", instance="dev-memory-000", earlier=1, family="memory")
    own = row("m", 0, True, task="dev-memory-000", instance="dev-memory-000", family="memory")
    failed = row("m", 0, False, task="dev-memory-001-pre1", instance="dev-memory-001", earlier=1, family="memory")
    not_run = row("m", 0, False, task="dev-memory-001", instance="dev-memory-001", outcome="not_run", family="memory")
    return [earlier, own, failed, not_run]


def test_an_earlier_task_is_no_trial_of_its_instance() -> None:
    assert _groups(_instance_rows(), []) == {("m", "dev-memory-000", 0): 1, ("m", "dev-memory-001", 0): 1}


def test_an_instance_not_run_has_no_trace_to_miss() -> None:
    rows = tuple(_instance_rows())
    study = Submission({"traces": ["0" * 64, "1" * 64, "2" * 64, None]}, rows).study("s")
    assert study.traced == (True, True, True, True)
