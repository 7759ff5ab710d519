"""Believed against actual success, two ways: ours counts every attempt (a task the agent never
ended counts as believed failure: it claimed nothing); the paper's (its Fig. 3) leaves stopped
attempts out and normalises each row of the ground truth. Either way a belief is judged against
the request being achieved (`robocog.shared.evaluation.achieved`): an honest failure on an
infeasible task is a true negative, a success claimed there a hallucination."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robocog.shared.evaluation import AttemptRow, achieved


@dataclass(frozen=True)
class Confusion:
    """Counts of (believed, actual): tp, fp (hallucinated success), fn, tn."""

    tp: int = 0
    fp: int = 0
    fn: int = 0
    tn: int = 0

    @property
    def grid(self) -> list[list[int]]:
        """Rows: believed success / failure; columns: actual success / failure."""
        return [[self.tp, self.fp], [self.fn, self.tn]]


def confusion(rows: list[AttemptRow]) -> Confusion:
    """Believed (end_task's status; never ended counts as failure) against actual success."""
    counts = {"tp": 0, "fp": 0, "fn": 0, "tn": 0}
    for r in rows:
        believed = r.believed_success is True
        key = ("t" if believed == achieved(r) else "f") + ("p" if believed else "n")
        counts[key] += 1
    return Confusion(**counts)


# A row of the paper's confusion matrix: (believed failure, believed success).
PairCounts = tuple[int, int]
PairShares = tuple[float | None, float | None]


@dataclass(frozen=True)
class PaperConfusion:
    """The paper's Fig. 3 for one model: rows are the ground truth (failure, success), columns the
    belief (failure, success); tasks and memory iterations pooled; stopped (and errored) attempts
    left out. `shares` normalises each row; a row without attempts has no shares (None)."""

    failure: PairCounts  # actual failure: believed failure, believed success (hallucinated)
    success: PairCounts  # actual success: believed failure, believed success

    @property
    def counts(self) -> tuple[PairCounts, PairCounts]:
        return (self.failure, self.success)

    @property
    def n(self) -> int:
        return sum(self.failure) + sum(self.success)

    @staticmethod
    def _shares(row: PairCounts) -> PairShares:
        total = sum(row)
        if total == 0:
            return (None, None)
        return (row[0] / total, row[1] / total)

    @property
    def shares(self) -> tuple[PairShares, PairShares]:
        """Row-normalised fractions (0..1), rows and columns as `counts`."""
        return (self._shares(self.failure), self._shares(self.success))

    def as_json(self) -> dict[str, Any]:
        return {
            "rows": ["actual failure", "actual success"],
            "columns": ["believed failure", "believed success"],
            "counts": [list(r) for r in self.counts],
            "row_shares": [list(r) for r in self.shares],
            "n": self.n,
        }


def paper_confusion(rows: list[AttemptRow]) -> PaperConfusion:
    """The paper's Fig. 3 from counted attempts: stopped ones are left out; belief is end_task's
    status being success."""
    counts = [[0, 0], [0, 0]]
    for r in rows:
        if r.outcome != "ended":
            continue
        counts[int(achieved(r))][int(r.believed_success is True)] += 1
    return PaperConfusion(failure=(counts[0][0], counts[0][1]), success=(counts[1][0], counts[1][1]))
