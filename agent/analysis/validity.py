"""Capability validity: each capability tag proven by ablation. `scripted/without-<tag>` is the oracle
with that one capability taken away (`robocog.agent.policies.ablations`); a tag measures what it says
when its ablation fails most instances tagged with it (the aim: at most 20% success) and passes
almost all the others (at least 95%).

From a study's rows: per ablation model found in them, its success (`robocog.shared.evaluation.success`;
errored attempts left out) on the instances tagged with its capability and on the rest, with Wilson
95% intervals, and the oracle's (`scripted/planner`) on the same two sets when it ran too. An
instance's earlier task is not an attempt at the instance (`instance_rows`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from robocog.agent.analysis.markdown_table import md_table, pct
from robocog.agent.analysis.stats import Interval, wilson
from robocog.shared.evaluation import AttemptRow, counted, instance_rows, success

#: The prefix of an ablation's model string.
ABLATION = "scripted/without-"
ORACLE = "scripted/planner"
#: The aims: an ablation succeeds on at most this share of its tagged instances ...
TAGGED_AIM = 0.2
#: ... and on at least this share of the others.
UNTAGGED_AIM = 0.95


@dataclass(frozen=True)
class Share:
    successes: int
    n: int

    @property
    def rate(self) -> float | None:
        return self.successes / self.n if self.n else None

    @property
    def interval(self) -> Interval | None:
        return wilson(self.successes, self.n) if self.n else None


def _share(rows: Sequence[AttemptRow]) -> Share:
    return Share(sum(success(r) for r in rows), len(rows))


@dataclass(frozen=True)
class Validity:
    """One ablation: its success on the instances tagged with its capability and on the others."""

    tag: str
    model: str
    tagged: Share
    untagged: Share
    oracle_tagged: Share | None
    oracle_untagged: Share | None

    @property
    def fails_tagged(self) -> bool:
        return self.tagged.rate is not None and self.tagged.rate <= TAGGED_AIM

    @property
    def passes_untagged(self) -> bool:
        return self.untagged.rate is not None and self.untagged.rate >= UNTAGGED_AIM


def capability_validity(rows: Sequence[AttemptRow]) -> list[Validity]:
    """Per ablation model in `rows` (in order of appearance), its validity table row."""
    kept = [r for r in instance_rows(list(rows)) if counted(r) and r.instance]
    oracle = [r for r in kept if r.model_id == ORACLE or r.model == ORACLE]
    out = []
    for model in dict.fromkeys(r.model for r in kept if (r.model_id or r.model).startswith(ABLATION)):
        mine = [r for r in kept if r.model == model]
        tag = (mine[0].model_id or model).removeprefix(ABLATION)
        ids = {r.instance for r in mine}
        on = [r for r in oracle if r.instance in ids]
        out.append(
            Validity(
                tag,
                model,
                _share([r for r in mine if tag in r.capabilities]),
                _share([r for r in mine if tag not in r.capabilities]),
                _share([r for r in on if tag in r.capabilities]) if on else None,
                _share([r for r in on if tag not in r.capabilities]) if on else None,
            )
        )
    return out


def _cell(share: Share | None) -> str:
    if share is None or not share.n or share.interval is None:
        return "n/a"
    low, high = share.interval
    return f"{pct(share.rate)} ({share.successes}/{share.n}; {pct(low)} – {pct(high)})"


def validity_section(table: Sequence[Validity]) -> list[str]:
    """The markdown section (nothing when no ablation ran)."""
    if not table:
        return []
    lines = [
        [
            v.tag.replace("_", " "),
            f"`{v.model}`",
            _cell(v.tagged),
            _cell(v.untagged),
            _cell(v.oracle_tagged),
            _cell(v.oracle_untagged),
            ("yes" if v.fails_tagged else "no") + " / " + ("yes" if v.passes_untagged else "no"),
        ]
        for v in table
    ]
    header = [
        "capability",
        "ablation",
        "success, tagged",
        "success, not tagged",
        "oracle, tagged",
        "oracle, not tagged",
        f"fails tagged (≤ {TAGGED_AIM:.0%}) / passes others (≥ {UNTAGGED_AIM:.0%})",
    ]
    return [
        "## Capability validity",
        "",
        "Each capability tag proven by ablation: the oracle with that one capability taken away "
        "(`scripted/without-<tag>`) should fail the instances tagged with it and pass the others. Success "
        "as everywhere (an infeasible instance's honest failure succeeds), 95% Wilson intervals.",
        "",
        md_table(header, lines),
        "",
    ]
