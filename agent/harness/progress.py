"""What a study's progress display counts: units done, attempts, successes and errored attempts."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from robocog.shared.evaluation import AttemptRow, success


@dataclass
class Progress:
    """Counts for the progress display."""

    total: int
    done: int = 0
    successes: int = 0
    attempts: int = 0
    errors: int = 0
    on_change: Callable[[Progress], None] | None = None
    on_error: Callable[[AttemptRow], None] | None = None

    def advance(self, n: int = 1, row: AttemptRow | None = None) -> None:
        self.done += n
        if row is not None and row.outcome == "error":
            self.errors += 1
            if self.on_error is not None:
                self.on_error(row)
        elif row is not None:
            self.attempts += 1
            self.successes += int(success(row))
        if self.on_change is not None:
            self.on_change(self)
