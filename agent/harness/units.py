"""A study's units (a model and a trial) and its attempts' identities: which units are still to
run, which tasks may run, and the ids and seeds an attempt carries (the same on a rerun).
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from robocog.agent.policies import model_seed as model_seed  # re-exported: units.model_seed
from robocog.shared.errors import ServerConnectionError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec


def slug(text: str) -> str:
    """`text` as a file name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "model"


def episode_id(study: str, model: str, seed: int, trial: int, iteration: int, task: str) -> str:
    """The server-side episode id of an attempt (begin_task): the same for a rerun of the attempt
    (`--resume` after a crash), so the server replaces its memory record instead of adding a second."""
    return (
        "eval-" + hashlib.sha256(f"{study}\x00{model}\x00{seed}:{trial}:{iteration}:{task}".encode()).hexdigest()[:32]
    )


def unit_namespace(study: str, model: str, trial: int) -> str:
    """The memory namespace of a unit (a model and a trial): its own, whichever robot runs it."""
    return "unit-" + hashlib.sha256(f"{study}\x00{model}\x00{trial}".encode()).hexdigest()[:24]


#: The error of an attempt during which the server or the transport died.
SERVER_FAILURE = "server failure"


class ServerBroke(ServerConnectionError):
    """The server died during an attempt; carries the attempt's row."""

    def __init__(self, row: AttemptRow) -> None:
        super().__init__(row.error)
        self.row = row


Requirements = Mapping[str, Sequence[str]]  # task id -> tasks that must have succeeded first


def runnable(task_id: str, succeeded: set[str], requires: Requirements) -> bool:
    """Whether every task `task_id` requires has truly succeeded (earlier in the same iteration)."""
    return all(r in succeeded for r in requires.get(task_id, ()))


def errored(rows: list[AttemptRow]) -> list[AttemptRow]:
    """The attempts that a failing model service or server cut short (outcome "error")."""
    return [r for r in rows if r.outcome == "error"]


def unit_complete(rows: list[AttemptRow], config: EvalConfig, requires: Requirements) -> bool:
    """A unit is complete when no attempt of it errored and its last memory iteration has closed:
    every task ran, or was skipped because a task it requires failed."""
    if errored(rows):
        return False
    # in run order; an instance's earlier tasks have rows of their own, beside the tasks'
    last = iter([r for r in rows if r.memory_iteration == config.memory_iterations - 1 and r.earlier is None])
    succeeded: set[str] = set()
    for task_id in config.tasks:
        if not runnable(task_id, succeeded, requires):
            continue
        row = next(last, None)
        if row is None or row.task != task_id:  # not run yet (or not by these rules: run it again)
            return False
        if row.true_success:
            succeeded.add(task_id)
    return True


def plan_units(
    config: EvalConfig, out: Path, rows: list[AttemptRow], requires: Requirements
) -> list[tuple[ModelSpec, int, int]]:
    """The units still to run, given the `rows` already in `out`; drops the rows of units that were
    cut off (rewriting `out`)."""
    by_unit: dict[tuple[str, int], list[AttemptRow]] = {}
    for row in rows:
        by_unit.setdefault(row.unit, []).append(row)
    complete = {unit for unit, unit_rows in by_unit.items() if unit_complete(unit_rows, config, requires)}
    kept = [r for r in rows if r.unit in complete]
    if len(kept) != len(rows):
        tmp = out.with_suffix(out.suffix + ".tmp")
        tmp.write_text("".join(r.model_dump_json() + "\n" for r in kept), encoding="utf-8")
        tmp.replace(out)
    return [
        (spec, trial, 0)
        for trial in range(config.trials)
        for spec in config.models
        if (spec.name, trial) not in complete
    ]
