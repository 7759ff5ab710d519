"""The statistics of a study, as typed data: intervals, pass^k, confusion, and `summarise`.

- Errored attempts follow the one policy (`robocog.shared.evaluation.ERRORED_POLICY`): every
  statistic leaves them out, and `Summary.errored` counts them per model and task.
- Success is `robocog.shared.evaluation.success` (an infeasible task's honest failure succeeds).
- Wilson 95% intervals for success rates; Student's t 95% intervals for means, clipped at 0 for
  tool calls (a count is never negative).
- pass^k: the chance that k independent trials all succeed, C(c, k) / C(n, k) over the n trials
  at each memory iteration, averaged over iterations.
- Confusion of believed against actual success, ours and the paper's (`robocog.agent.analysis.confusion`).
- Results of two protocols in one file: `by_protocol` names each model once per protocol.

`Summary.as_json()` is what `summary.json` holds.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import asdict, dataclass
from statistics import mean, stdev
from typing import Any

from robocog.agent.analysis.confusion import Confusion, PaperConfusion, confusion, paper_confusion
from robocog.shared.evaluation import AttemptRow, success
from robocog.shared.evaluation import counted as is_counted

Z95 = 1.959963984540054
# Two-sided 95% quantiles of Student's t for small samples (df 1..30); the normal beyond.
_T95 = [
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
]

#: The k of the pass^k columns.
PASS_KS = (1, 2, 4, 8)

Interval = tuple[float, float]


def wilson(successes: float, n: int, z: float = Z95) -> Interval:
    """Wilson score interval of a binomial proportion."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    low = 0.0 if successes <= 0 else max(0.0, centre - half)  # exactly the bounds at 0 and n
    high = 1.0 if successes >= n else min(1.0, centre + half)
    return (low, high)


def mean_interval(values: list[float]) -> tuple[float, float, float]:
    """Mean and its 95% t interval; no interval (NaN bounds) from fewer than two values: one value
    says nothing of the spread, and (m, m) would read as certainty."""
    if not values:
        return (math.nan, math.nan, math.nan)
    m = mean(values)
    if len(values) < 2:
        return (m, math.nan, math.nan)
    t = _T95[len(values) - 2] if len(values) - 1 <= len(_T95) else Z95
    half = t * stdev(values) / math.sqrt(len(values))
    return (m, m - half, m + half)


def pass_hat_k(successes: int, n: int, k: int) -> float:
    """Unbiased estimate that k trials drawn without replacement all succeed."""
    if k > n:
        return math.nan
    return math.comb(successes, k) / math.comb(n, k)


@dataclass
class Cell:
    """Aggregates of one group of attempts."""

    n: int
    successes: int
    believed: int
    agreements: int
    stopped: int
    tool_calls: float
    tokens_in: float
    tokens_out: float
    cost: float | None
    llm_latency_s: float
    wall_s: float

    @classmethod
    def of(cls, rows: list[AttemptRow]) -> Cell:
        """Aggregate a non-empty group of attempts."""
        costs = [r.cost for r in rows if r.cost is not None]
        return cls(
            n=len(rows),
            successes=sum(success(r) for r in rows),
            believed=sum(r.believed_success is True for r in rows),
            agreements=sum(r.agreement is True for r in rows),  # None: an errored attempt
            stopped=sum(r.outcome == "stopped" for r in rows),
            tool_calls=mean(r.tool_calls for r in rows),
            tokens_in=mean(r.tokens_in for r in rows),
            tokens_out=mean(r.tokens_out for r in rows),
            cost=sum(costs) if costs else None,
            llm_latency_s=mean(r.llm_latency_s for r in rows),
            wall_s=mean(r.wall_s for r in rows),
        )

    @property
    def rate(self) -> float:
        return self.successes / self.n if self.n else math.nan


@dataclass(frozen=True)
class IterationPoint:
    """One model, task and memory iteration: success rate (stopped attempts included, as failures)
    and tool calls with 95% intervals, and the tool calls of the attempts that ended (the paper's
    Fig. 5 leaves stopped ones out)."""

    memory_iteration: int
    n: int
    successes: int
    stopped: int
    rate: float
    rate_ci: Interval
    tool_calls: float
    tool_calls_ci: Interval
    ended_tool_calls: tuple[int, ...]


@dataclass(frozen=True)
class TableRow:
    """One model on one task, over every trial and memory iteration (errored attempts left out)."""

    model: str
    task: str
    executions: int
    successes: int
    rate: float
    rate_ci: Interval
    believed: int
    agreement: float
    stopped: int
    tool_calls: float
    tokens_in: float
    tokens_out: float
    cost: float | None
    llm_latency_s: float
    wall_s: float
    confusion: Confusion
    pass_hat: dict[int, float]  # k -> pass^k, only for the k some iteration has enough trials for
    by_memory_iteration: tuple[IterationPoint, ...]

    def as_json(self) -> dict[str, Any]:
        """The row as `summary.json` holds it: pass^k as `pass^1`, ... keys before the iterations."""
        out = asdict(self)
        del out["pass_hat"]
        points = out.pop("by_memory_iteration")
        out.update({f"pass^{k}": v for k, v in self.pass_hat.items()})
        out["by_memory_iteration"] = points
        return out

    def point(self, memory_iteration: int) -> IterationPoint | None:
        """The point of one memory iteration, if the task ran at it."""
        return next((p for p in self.by_memory_iteration if p.memory_iteration == memory_iteration), None)


#: How long an error message may be in the report's table.
ERROR_CHARS = 90


def shorten(message: str, limit: int = ERROR_CHARS) -> str:
    """The first line of a message, cut to `limit` characters with an ellipsis."""
    first = message.strip().splitlines()[0] if message.strip() else ""
    return first if len(first) <= limit else first[: limit - 1].rstrip() + "…"


@dataclass(frozen=True)
class Errored:
    """The errored attempts of one model on one task."""

    model: str
    task: str
    attempts: int  # every attempt, errored ones included
    errored: int
    first_error: str  # the first errored attempt's message, shortened


@dataclass(frozen=True)
class Summary:
    """Every number the report shows. `attempts` counts every row; the statistics use the
    `counted` ones (outcome ended or stopped)."""

    models: tuple[str, ...]
    tasks: tuple[str, ...]
    attempts: int
    counted: int
    protocols: dict[str, int]  # protocol -> attempts, in order of first appearance
    errored: tuple[Errored, ...]  # only the model and task pairs with an errored attempt
    table: tuple[TableRow, ...]
    confusion: dict[str, Confusion]  # per model, over every task (ours: every counted attempt)
    paper_confusion: dict[str, PaperConfusion]  # per model, the paper's Fig. 3
    memory_iterations: tuple[int, ...]  # every memory iteration some counted attempt ran at

    def rows_for(self, task: str) -> list[TableRow]:
        """The table's rows of one task, in model order."""
        return [r for r in self.table if r.task == task]

    def row(self, model: str, task: str) -> TableRow | None:
        return next((r for r in self.table if (r.model, r.task) == (model, task)), None)

    @property
    def reported_models(self) -> tuple[str, ...]:
        """The models with at least one counted attempt (the figures' panels)."""
        return tuple(m for m in self.models if any(r.model == m for r in self.table))

    @property
    def errored_total(self) -> int:
        return sum(e.errored for e in self.errored)

    def as_json(self) -> dict[str, Any]:
        """What `summary.json` holds."""
        return {
            "models": list(self.models),
            "tasks": list(self.tasks),
            "attempts": self.attempts,
            "counted": self.counted,
            "errored_total": self.errored_total,
            "protocols": dict(self.protocols),
            "errored": [asdict(e) for e in self.errored],
            "table": [r.as_json() for r in self.table],
            "confusion": {m: asdict(c) for m, c in self.confusion.items()},
            "paper_confusion": {m: c.as_json() for m, c in self.paper_confusion.items()},
        }


def _order(values: list[str]) -> tuple[str, ...]:
    return tuple(dict.fromkeys(values))


def by_protocol(rows: list[AttemptRow]) -> list[AttemptRow]:
    """Rows of one protocol unchanged; rows of several get the protocol in the model's name
    ("gpt-4.1 (paper)"), so every table and figure sets the protocols side by side."""
    if len({r.protocol for r in rows}) < 2:
        return rows
    return [r.model_copy(update={"model": f"{r.model} ({r.protocol})"}) for r in rows]


def _point(iteration: int, rows: list[AttemptRow]) -> IterationPoint:
    s = sum(success(r) for r in rows)
    tm, tlo, thi = mean_interval([float(r.tool_calls) for r in rows])
    return IterationPoint(
        memory_iteration=iteration,
        n=len(rows),
        successes=s,
        stopped=sum(r.outcome == "stopped" for r in rows),
        rate=s / len(rows),
        rate_ci=wilson(s, len(rows)),
        tool_calls=tm,
        tool_calls_ci=(tlo if math.isnan(tlo) else max(0.0, tlo), thi),
        ended_tool_calls=tuple(r.tool_calls for r in rows if r.outcome == "ended"),
    )


def _table_row(model: str, task: str, rows: list[AttemptRow], by_iter: dict[int, list[AttemptRow]]) -> TableRow:
    c = Cell.of(rows)
    iters = sorted(by_iter)
    pass_hat: dict[int, float] = {}
    for k in PASS_KS:
        values = [
            pass_hat_k(sum(success(r) for r in by_iter[i]), len(by_iter[i]), k) for i in iters if len(by_iter[i]) >= k
        ]
        if values:
            pass_hat[k] = round(mean(values), 4)
    return TableRow(
        model=model,
        task=task,
        executions=c.n,
        successes=c.successes,
        rate=c.rate,
        rate_ci=wilson(c.successes, c.n),
        believed=c.believed,
        agreement=c.agreements / c.n,
        stopped=c.stopped,
        tool_calls=c.tool_calls,
        tokens_in=c.tokens_in,
        tokens_out=c.tokens_out,
        cost=c.cost,
        llm_latency_s=c.llm_latency_s,
        wall_s=c.wall_s,
        confusion=confusion(rows),
        pass_hat=pass_hat,
        by_memory_iteration=tuple(_point(i, by_iter[i]) for i in iters),
    )


def _errored(models: tuple[str, ...], tasks: tuple[str, ...], rows: list[AttemptRow]) -> tuple[Errored, ...]:
    out = []
    for m in models:
        for t in tasks:
            mine = [r for r in rows if (r.model, r.task) == (m, t)]
            failed = [r for r in mine if r.outcome == "error"]
            if failed:
                first = failed[0].error or "(no message recorded)"
                out.append(
                    Errored(model=m, task=t, attempts=len(mine), errored=len(failed), first_error=shorten(first))
                )
    return tuple(out)


def summarise(rows: list[AttemptRow]) -> Summary:
    """Every number the report shows, as data (models and tasks in order of first appearance).
    Errored attempts are counted apart and left out of every statistic."""
    models = _order([r.model for r in rows])
    tasks = _order([r.task for r in rows])
    counted = [r for r in rows if is_counted(r)]
    groups: dict[tuple[str, str], list[AttemptRow]] = defaultdict(list)
    by_iter: dict[tuple[str, str], dict[int, list[AttemptRow]]] = defaultdict(lambda: defaultdict(list))
    for r in counted:
        groups[(r.model, r.task)].append(r)
        by_iter[(r.model, r.task)][r.memory_iteration].append(r)
    table = tuple(
        _table_row(m, t, groups[(m, t)], by_iter[(m, t)]) for m in models for t in tasks if groups.get((m, t))
    )
    protocols: dict[str, int] = {}
    for r in rows:
        protocols[r.protocol] = protocols.get(r.protocol, 0) + 1
    return Summary(
        models=models,
        tasks=tasks,
        attempts=len(rows),
        counted=len(counted),
        protocols=protocols,
        errored=_errored(models, tasks, rows),
        table=table,
        confusion={m: confusion([r for r in counted if r.model == m]) for m in models},
        paper_confusion={m: paper_confusion([r for r in counted if r.model == m]) for m in models},
        memory_iterations=tuple(sorted({r.memory_iteration for r in counted})),
    )
