"""Rows' provenance, checked: where the rows of one file disagree on what they ran on, and whether they
ran on what robocog ships (the leaderboard's *verified* mark).

What must agree: across the whole file, robocog's version, the contract's version, the physics build
(upstream pybullet or its fork, and the version), the protocol and the study's seed (a row's seed less
its trial); per model, its model string, its sampling parameters,
the tools it was offered and the system prompt; per task, the task's digest. Rows written before
provenance existed carry none: a file with some is said to mix them.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robocog.shared.evaluation import AttemptRow
from robocog.shared.protocol import CONTRACT_VERSION
from robocog.shared.provenance import (
    canonical_json,
    shipped_prompt_sha256,
    shipped_task_sha256,
    shipped_tools_sha256,
)

#: What rows must agree on across a file: a name and how to read it off a row.
FILE_WIDE: tuple[tuple[str, Callable[[AttemptRow], Any]], ...] = (
    ("robocog version", lambda r: r.version),
    ("contract version", lambda r: r.provenance.contract if r.provenance else None),
    ("physics build", lambda r: r.provenance.physics if r.provenance else None),
    ("protocol", lambda r: r.protocol),
    ("study seed", lambda r: r.seed - r.trial),
)
#: What the rows of one model must agree on.
PER_MODEL: tuple[tuple[str, Callable[[AttemptRow], Any]], ...] = (
    ("model string", lambda r: r.model_id or None),
    ("sampling parameters", lambda r: canonical_json(r.provenance.params).decode() if r.provenance else None),
    ("tools", lambda r: r.provenance.tools_sha256[:12] if r.provenance else None),
    ("system prompt", lambda r: r.provenance.system_prompt_sha256[:12] if r.provenance else None),
)


def _spread(rows: Sequence[AttemptRow], read: Callable[[AttemptRow], Any]) -> Counter[str]:
    return Counter(str(read(r)) for r in rows if r.provenance is not None or read(r) is not None)


def _said(what: str, counts: Counter[str], where: str = "") -> str:
    values = ", ".join(f"{value} ({n} rows)" for value, n in counts.most_common())
    return f"rows{where} disagree on the {what}: {values}"


def disagreements(rows: Sequence[AttemptRow]) -> list[str]:
    """One line per thing the rows of one file disagree on (none: they agree)."""
    lines = []
    missing = sum(r.provenance is None for r in rows)
    if 0 < missing < len(rows):
        lines.append(f"{missing} of {len(rows)} rows carry no provenance (written by a robocog before it)")
    for what, read in FILE_WIDE:
        counts = _spread(rows, read)
        if len(counts) > 1:
            lines.append(_said(what, counts))
    by_model: dict[str, list[AttemptRow]] = defaultdict(list)
    by_task: dict[str, list[AttemptRow]] = defaultdict(list)
    for r in rows:
        by_model[r.model].append(r)
        if r.provenance is not None:
            by_task[r.task].append(r)
    for model, group in by_model.items():
        for what, read in PER_MODEL:
            counts = _spread(group, read)
            if len(counts) > 1:
                lines.append(_said(what, counts, f" of {model}"))
    for task, group in by_task.items():
        counts = Counter(str(r.provenance.task_sha256)[:12] for r in group if r.provenance)
        if len(counts) > 1:
            lines.append(_said("task's digest", counts, f" of {task}"))
    return lines


@dataclass(frozen=True)
class Verification:
    """Whether rows ran on what robocog ships, with every trace present; `problems` says why not."""

    problems: tuple[str, ...]

    @property
    def verified(self) -> bool:
        return not self.problems


def row_problems(row: AttemptRow) -> list[str]:
    """How one row departs from what robocog ships (its trace aside)."""
    p = row.provenance
    if p is None:
        return ["no provenance"]
    out = []
    if p.contract != CONTRACT_VERSION:
        out.append(f"contract {p.contract} (shipped: {CONTRACT_VERSION})")
    if shipped_tools_sha256(p.tools) != p.tools_sha256:
        out.append("tools differ from the shipped contract's")
    if shipped_prompt_sha256(p.system_prompt) != p.system_prompt_sha256:
        out.append(f"system prompt {p.system_prompt} differs from the shipped one")
    fresh = None if p.split_seed is None else f"{p.split}@{p.split_seed}"
    if shipped_task_sha256(row.task, p.suite, fresh) != p.task_sha256:
        out.append(f"task {row.task} differs from the shipped one")
    return out


def verify(rows: Sequence[AttemptRow], traces: Callable[[AttemptRow], bool]) -> Verification:
    """Whether every row ran on the shipped prompts, tools and task files and has its trace (`traces`
    says whether a row's trace is present); the problems counted, most common first."""
    problems: Counter[str] = Counter()
    for r in rows:
        problems.update(row_problems(r))
        if not traces(r):
            problems["trace missing"] += 1
    return Verification(tuple(f"{what} ({n} rows)" for what, n in problems.most_common()))


def trace_on_disk(base: Path) -> Callable[[AttemptRow], bool]:
    """Whether a row's trace file exists, relative to the results file's folder `base` (an instance not
    run has none to have: its earlier task's row carries the trace)."""
    return lambda r: r.outcome == "not_run" or (bool(r.trace) and (base / str(r.trace)).is_file())
