"""The leaderboard: studies side by side, one entry per model and protocol.

Each entry pools its model's rows (under one protocol) from every study given, and scores them with
the per-family code (`robocog.agent.analysis.scores.family_row`, errored attempts left out and counted
apart: `robocog.shared.evaluation.ERRORED_POLICY`): success with its Wilson 95% interval, the
false-success rate with its interval, pass^k with its interval, success per family and per capability
tag (rows that carry `capabilities`; robocog-v1's rows carry none, so no capability column appears), tokens and cost per
attempt where known (rows whose cost is unknown are left out of the cost's mean; none known: n/a).

An entry is *verified* when every row of it ran on the prompts, tools and task files robocog ships,
every trace is present (`robocog.agent.analysis.provenance.verify`) and every attempt, replayed in
the physics from its trace (`robocog submit verify`, whose record lies beside the study:
`robocog.agent.analysis.replay_record`), gave its recorded verdict; rows written before provenance
existed are never verified, but they are scored like any other.

A study is a results file (JSONL, its traces beside it) or a submission (`robocog submit prepare`),
read by `submission.load_study`; `board` builds the entries, `board_json` and `board_markdown` write
them, and `draw_success_cost` plots success against cost per attempt.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robocog.agent.analysis.markdown_table import cell, md_table, pct
from robocog.agent.analysis.provenance import Verification, disagreements, trace_on_disk, verify
from robocog.agent.analysis.scores import FamilyRow, capability_groups, family_of, family_row
from robocog.shared import __version__
from robocog.shared.evaluation import AttemptRow, instance_rows

FIGURE = "success_cost.png"


@dataclass(frozen=True)
class Study:
    """A study's rows and, for each, whether its trace is present and how its replay went
    (`robocog.agent.analysis.replay_record.STATUSES`; None: the study was not replayed)."""

    name: str
    rows: tuple[AttemptRow, ...]
    traced: tuple[bool, ...]
    replayed: tuple[str, ...] | None = None


def results_study(path: Path) -> Study:
    """A results file written by `robocog eval` (a regular file within its bound), its traces looked for
    beside it."""
    from robocog.agent.analysis.results_file import load_rows
    from robocog.agent.analysis.untrusted import RESULTS_BYTES, read_bounded

    read_bounded(path, RESULTS_BYTES, "results file", content=False)
    rows = load_rows(path)
    if not rows:
        raise ValueError(f"{path}: the results file holds no attempts")
    present = trace_on_disk(path.resolve().parent)
    return Study(path.name, tuple(rows), tuple(present(r) for r in rows))


@dataclass(frozen=True)
class Entry:
    """One model under one protocol, its rows pooled over the studies."""

    model: str
    protocol: str
    studies: tuple[str, ...]
    model_ids: tuple[str, ...]
    overall: FamilyRow
    families: dict[str, FamilyRow]
    capabilities: dict[str, FamilyRow]
    tokens_per_attempt: float | None
    cost_per_attempt: float | None
    cost_known: int
    verification: Verification
    #: Attempts replayed in the physics (`robocog submit verify`), of those there are to replay.
    replayed: int = 0
    replayable: int = 0
    #: What the rows ran on (`Split`): the suite, its split, and the seed of a fresh split (None: shipped).
    split: Split = (None, None, None)

    @property
    def name(self) -> str:
        seed = self.split[2]
        return f"{self.model} ({self.protocol})" if seed is None else f"{self.model} ({self.protocol}, seed {seed})"

    @property
    def split_shown(self) -> str:
        """The split as the page shows it: "robocog-v2.1 / test@12345" for a fresh split, "shipped" for
        rows of the shipped splits and tasks (pooled as they always were)."""
        suite, split, seed = self.split
        return "shipped" if seed is None else f"{suite} / {split}@{seed}"


@dataclass(frozen=True)
class Board:
    studies: tuple[Study, ...]
    entries: tuple[Entry, ...]
    families: tuple[str, ...]
    capabilities: tuple[str, ...]
    ks: tuple[int, ...]
    warnings: tuple[str, ...] = field(default=())

    @property
    def fresh(self) -> bool:
        """Whether an entry ran on a fresh split: the board then shows a split column."""
        return any(e.split[2] is not None for e in self.entries)


def _mean(values: list[float]) -> float | None:
    return sum(values) / len(values) if values else None


#: A row, where it came from, whether its trace is present and how its replay went (None: not replayed).
Pair = tuple[str, AttemptRow, bool, str | None]
#: A fresh split's suite, split and seed, the leaderboard's groups; (None, None, None) for the rows of
#: the splits and tasks robocog ships, which pool as they always did.
Split = tuple[str | None, str | None, int | None]


def _splits(rows: Sequence[AttemptRow]) -> list[Split]:
    """Each row's `Split`, from its provenance; an instance's earlier task (whose provenance names no
    split) takes its instance's."""

    def own(r: AttemptRow) -> Split:
        p = r.provenance
        return (None, None, None) if p is None or p.split_seed is None else (p.suite, p.split, p.split_seed)

    of_instance = {r.instance: own(r) for r in rows if r.instance and r.earlier is None}
    return [of_instance.get(r.instance or "", own(r)) if r.earlier is not None else own(r) for r in rows]


def _replay_problems(pairs: Sequence[Pair]) -> tuple[list[str], int, int]:
    """Why rows are not verified by replay (their replay differs, or there is none), the attempts
    replayed and those there are to replay (an errored attempt or an instance not run has none)."""
    due = [status for _, r, _, status in pairs if r.outcome not in ("error", "not_run")]
    differs = sum(s == "differs" for s in due)
    missing = sum(s not in ("matches", "differs") for s in due)
    problems = [f"replay differs ({differs} rows)"] if differs else []
    problems += [f"not replayed ({missing} rows)"] if missing else []
    return problems, sum(s in ("matches", "differs") for s in due), len(due)


def entry(model: str, protocol: str, pairs: list[Pair], split: Split = (None, None, None)) -> Entry:
    """The entry of `model` under `protocol` from its (study, row, trace present, replay) tuples:
    verified when its rows ran on what robocog ships, their traces are present, and every attempt's
    replay gave its verdict."""
    every = [r for _, r, _, _ in pairs]
    traced = {id(r): t for _, r, t, _ in pairs}
    replay_problems, replayed, replayable = _replay_problems(pairs)
    shipped = verify(every, lambda r: traced[id(r)])
    rows = instance_rows(every)  # an instance's earlier task is no attempt at the instance
    by_family: dict[str, list[AttemptRow]] = defaultdict(list)
    for r in rows:
        by_family[family_of(r)].append(r)
    costs = [r.cost for r in rows if r.cost is not None]
    return Entry(
        model=model,
        protocol=protocol,
        studies=tuple(dict.fromkeys(s for s, _, _, _ in pairs)),
        model_ids=tuple(dict.fromkeys(r.model_id for r in rows if r.model_id)),
        overall=family_row(model, "all", rows),
        families={f: family_row(model, f, group) for f, group in by_family.items()},
        capabilities={c: family_row(model, c, group) for c, group in capability_groups(rows).items()},
        tokens_per_attempt=_mean([float(r.tokens_in + r.tokens_out) for r in rows]),
        cost_per_attempt=_mean(costs),
        cost_known=len(costs),
        verification=Verification(shipped.problems + tuple(replay_problems)),
        replayed=replayed,
        replayable=replayable,
        split=split,
    )


def _attempt_key(r: AttemptRow, split: Split) -> tuple[object, ...]:
    # the same ids on two fresh splits are two attempts (an earlier task's split is its instance's)
    return (r.study, r.model, r.protocol, r.seed, r.trial, r.memory_iteration, r.task, split)


def board(studies: Sequence[Study]) -> Board:
    """The leaderboard of `studies`: one entry per model and protocol, and per fresh split (suite, split
    and seed: `Split`; two seeds never pool, nor a fresh split with the shipped ones), grouped by split
    in the order the studies first show it, then by success (highest first), then by name. A ValueError
    when two studies hold the same attempts (a study given twice, as results and as a submission)."""
    seen: dict[tuple[object, ...], str] = {}
    for s in studies:
        for key in dict.fromkeys(_attempt_key(r, split) for r, split in zip(s.rows, _splits(s.rows), strict=True)):
            if key in seen:
                raise ValueError(f"{seen[key]} and {s.name} hold the same attempts (study {key[0]!r}): give each once")
            seen[key] = s.name
    grouped: dict[tuple[str, str, Split], list[Pair]] = defaultdict(list)
    warnings = []
    for s in studies:
        replays = s.replayed or (None,) * len(s.rows)
        for r, t, replay, split in zip(s.rows, s.traced, replays, _splits(s.rows), strict=True):
            grouped[(r.model, r.protocol, split)].append((s.name, r, t, replay))
        warnings += [f"{s.name}: {line}" for line in disagreements(s.rows)]
    order = {split: i for i, split in enumerate(dict.fromkeys(split for _, _, split in grouped))}
    entries = sorted(
        (entry(m, p, pairs, split) for (m, p, split), pairs in grouped.items()),
        key=lambda e: (order[e.split], -e.overall.success, e.name),
    )
    families = tuple(dict.fromkeys(f for e in entries for f in e.families))
    capabilities = tuple(sorted({c for e in entries for c in e.capabilities}))
    ks = tuple(sorted({k for e in entries for k in e.overall.pass_k}))
    return Board(tuple(studies), tuple(entries), families, capabilities, ks, tuple(warnings))


def _interval(ci: tuple[float, float] | None) -> list[float] | None:
    return None if ci is None or any(math.isnan(v) for v in ci) else [round(v, 4) for v in ci]


def _score(row: FamilyRow) -> dict[str, Any]:
    return {"success": round(row.success, 4), "ci": _interval(row.success_ci), "attempts": row.attempts}


def _ci_text(ci: tuple[float, float] | None) -> str:
    """An interval as it is shown ("[58.1%, 72.3%]"; "" for none), each bound rounded once, from the
    unrounded value."""
    if ci is None or any(math.isnan(v) for v in ci):
        return ""
    return f"[{pct(ci[0])}, {pct(ci[1])}]"


def shown(e: Entry, b: Board) -> dict[str, Any]:
    """Every number of an entry as the page and leaderboard.md both show it: each rounded once, from
    the counts' own ratio (never from a value already rounded for the JSON), so the two agree digit
    for digit."""
    o = e.overall
    return {
        "success": pct(o.success),
        "success_ci": _ci_text(o.success_ci),
        "false_success": pct(o.false_success_rate),
        "false_success_ci": _ci_text(o.false_success_ci) if o.false_success_rate is not None else "",
        "never_ended": str(o.stopped),
        "pass_k": {str(k): pct(o.pass_k.get(k)) for k in b.ks},
        "pass_k_ci": {str(k): _ci_text(o.pass_k_ci.get(k)) for k in b.ks},
        "families": {f: pct(e.families[f].success) if f in e.families else "–" for f in b.families},
        "capabilities": {c: pct(e.capabilities[c].success) if c in e.capabilities else "–" for c in b.capabilities},
        "tokens_per_attempt": "n/a" if e.tokens_per_attempt is None else f"{e.tokens_per_attempt:.0f}",
        "cost_per_attempt": "n/a" if e.cost_per_attempt is None else f"${e.cost_per_attempt:.4f}",
        "replayed": f"{e.replayed} of {e.replayable} replayed",
        "split": e.split_shown,
    }


def entry_json(e: Entry, b: Board | None = None) -> dict[str, Any]:
    o = e.overall
    out = {
        "model": e.model,
        "protocol": e.protocol,
        "model_ids": list(e.model_ids),
        "studies": list(e.studies),
        "verified": e.verification.verified,
        "problems": list(e.verification.problems),
        "attempts": o.attempts,
        "errored": o.errored,
        "success": round(o.success, 4),
        "success_ci": _interval(o.success_ci),
        "false_success_rate": None if o.false_success_rate is None else round(o.false_success_rate, 4),
        "false_success_ci": _interval(o.false_success_ci),
        "never_ended": o.stopped,
        "pass_k": {str(k): v for k, v in o.pass_k.items()},
        "pass_k_ci": {str(k): _interval(v) for k, v in o.pass_k_ci.items()},
        "families": {f: _score(s) for f, s in e.families.items()},
        "capabilities": {c: _score(s) for c, s in e.capabilities.items()},
        "tokens_per_attempt": None if e.tokens_per_attempt is None else round(e.tokens_per_attempt, 1),
        "cost_per_attempt": e.cost_per_attempt,
        "cost_known": e.cost_known,
        "replayed": e.replayed,
        "replayable": e.replayable,
        "suite": e.split[0],
        "split": e.split[1],
        "seed": e.split[2],
    }
    if b is not None:
        out["shown"] = shown(e, b)
    return out


def board_json(b: Board) -> dict[str, Any]:
    """The leaderboard as JSON (what the page shows, and leaderboard.json)."""
    return {
        "robocog_version": __version__,
        "studies": [{"name": s.name, "attempts": len(s.rows)} for s in b.studies],
        "families": list(b.families),
        "capabilities": list(b.capabilities),
        "ks": list(b.ks),
        "fresh_splits": b.fresh,
        "warnings": list(b.warnings),
        "entries": [entry_json(e, b) for e in b.entries],
    }


def _with_ci(value: str, ci: str) -> str:
    return f"{value} {ci}" if ci else value


def board_markdown(b: Board) -> str:
    """The leaderboard as a markdown table (leaderboard.md), its numbers those of the page (`shown`)."""
    header = ["#", "model", "protocol", *(["split"] if b.fresh else []), "verified", "attempts"]
    header += ["success [95% CI]", "false success", "never ended"]
    header += [f"pass^{k}" for k in b.ks] + list(b.families) + [f"cap. {c}" for c in b.capabilities]
    header += ["tokens / attempt", "cost / attempt"]
    lines = []
    for i, e in enumerate(b.entries, 1):
        t = shown(e, b)
        mark = f"{'yes' if e.verification.verified else 'no'} ({t['replayed']})"
        line = [str(i), cell(e.model), e.protocol, *([cell(t["split"])] if b.fresh else []), mark]
        line += [str(e.overall.attempts)]
        line += [_with_ci(t["success"], t["success_ci"]), _with_ci(t["false_success"], t["false_success_ci"])]
        line += [t["never_ended"]]
        line += [_with_ci(t["pass_k"][str(k)], t["pass_k_ci"][str(k)]) for k in b.ks]
        line += [t["families"][f] for f in b.families] + [t["capabilities"][c] for c in b.capabilities]
        line += [t["tokens_per_attempt"], t["cost_per_attempt"]]
        lines.append(line)
    parts = ["# robocog leaderboard", "", f"Studies: {', '.join(s.name for s in b.studies)}.", ""]
    parts += [md_table(header, lines), ""]
    unverified = [e for e in b.entries if not e.verification.verified]
    if unverified:
        parts += ["Not verified:", ""]
        parts += [f"- {cell(e.name)}: {'; '.join(e.verification.problems)}" for e in unverified]
        parts += [""]
    if b.warnings:
        parts += ["Provenance disagreements within a study:", ""] + [f"- {w}" for w in b.warnings] + [""]
    parts += [f"![success against cost per attempt]({FIGURE})", ""]
    return "\n".join(parts)


def draw_success_cost(b: Board, out: Path) -> str:
    """Success (with its 95% interval) against cost per attempt, one point per entry; entries whose
    cost is unknown sit on a strip at the left, marked "cost unknown". Returns the file name."""
    from robocog.agent.analysis.figure_layout import TAB10, new_figure

    fig = new_figure(7.2, 4.6)
    ax = fig.add_subplot(1, 1, 1)
    known = [e.cost_per_attempt for e in b.entries if e.cost_per_attempt is not None]
    top = max(known, default=0.0) or 1.0
    unknown_x = -0.08 * top
    placed: list[tuple[float, float]] = []  # labels already written: a close one moves its neighbour down
    for i, e in enumerate(b.entries):
        o = e.overall
        x = unknown_x if e.cost_per_attempt is None else e.cost_per_attempt
        near = sum(abs(px - x) < 0.02 * top and abs(py - o.success) < 0.05 for px, py in placed)
        placed.append((x, o.success))
        low, high = o.success_ci
        ax.errorbar(
            [x],
            [o.success],
            yerr=[[max(0.0, o.success - low)], [max(0.0, high - o.success)]],
            fmt="o" if e.verification.verified else "s",
            color=TAB10[i % len(TAB10)],
            capsize=3,
            markersize=7,
            mfc="white" if not e.verification.verified else None,
        )
        ax.annotate(e.name, (x, o.success), textcoords="offset points", xytext=(6, 4 - 9 * near), fontsize=7)
    if len(known) < len(b.entries):
        ax.axvline(unknown_x / 2, color="grey", linewidth=0.6, linestyle=":")
        ax.text(unknown_x, -0.04, "cost\nunknown", fontsize=7, ha="center", va="top", color="grey")
    ax.set_xlim(unknown_x * 1.8, top * 1.35)
    ax.set_ylim(-0.12, 1.05)
    ax.set_xlabel("cost per attempt (USD, mean over the attempts whose cost is known)")
    ax.set_ylabel("success (95% Wilson interval)")
    ax.grid(alpha=0.3)
    ax.set_title("Success against cost per attempt (filled circle: verified; open square: not)", fontsize=9)
    path = out / FIGURE
    fig.savefig(path)
    return path.name
