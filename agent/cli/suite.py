"""`robocog suite generate | list`: a split's instances written byte-identically, the families and
the instances of the shipped splits.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from robocog.shared.errors import ConfigError


def add_parser(commands: Any) -> argparse.ArgumentParser:
    """`robocog suite` and its subcommands."""
    parser: argparse.ArgumentParser = commands.add_parser(
        "suite", help="the robocog suite: generate a split's instances, list families and instances"
    )
    sub = parser.add_subparsers(dest="suite_command", required=True)
    gen = sub.add_parser("generate", help="generate a split's instances (byte-identical for the same seed)")
    gen.add_argument("--suite", default=None, help="suite name or directory (default: the suite robocog ships)")
    gen.add_argument("--split", default="dev", help="the split (its seed and size come from suite.yaml)")
    gen.add_argument("--seed", type=int, default=None, help="override the split's seed")
    gen.add_argument("--per-family", type=int, default=None, help="override the instances per family")
    gen.add_argument("-o", "--out", type=Path, default=None, help="write the JSONL here (default: stdout)")
    gen.add_argument(
        "--workers", type=int, default=1, help="processes drawing families side by side (the same bytes; default 1)"
    )
    ls = sub.add_parser("list", help="the suite's families and the instances of its splits")
    ls.add_argument("--suite", default=None, help="suite name or directory (default: the suite robocog ships)")
    ls.add_argument("--split", default=None, help="list this split's instances, one a line")
    return parser


def _table(rows: Iterable[tuple[str, ...]]) -> str:
    rows = list(rows)
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows)


def main(args: argparse.Namespace) -> int:
    """`robocog suite generate | list`."""
    from robocog.agent.suitegen.generator import generate  # the families, the symbolic world: only here
    from robocog.shared.family_files import load_families
    from robocog.shared.suite import DEFAULT_SUITE, dump_instances, load_split, load_suite, suite_dir

    args.suite = args.suite or DEFAULT_SUITE
    suite = load_suite(args.suite)
    if args.suite_command == "generate":
        if args.per_family is not None and args.per_family < 1:
            raise ConfigError(f"--per-family: must be at least 1, not {args.per_family}")
        if args.workers < 1:
            raise ConfigError(f"--workers: must be at least 1, not {args.workers}")
        text = dump_instances(
            generate(
                suite,
                args.split,
                seed=args.seed,
                per_family=args.per_family,
                workers=args.workers,
                directory=suite_dir(args.suite),
            )
        )
        if args.out is None:
            sys.stdout.write(text)
        else:
            args.out.write_bytes(text.encode("utf-8"))
            print(f"robocog: {text.count(chr(10))} instances -> {args.out}", file=sys.stderr)
        return 0
    if args.split is not None:
        instances = load_split(args.suite, args.split)
        print(
            _table(
                [("id", "scene", "feasible", "optimal", "prompt")]
                + [(i.id, i.scene, str(i.feasible).lower(), str(i.optimal_steps), i.prompt) for i in instances]
            )
        )
        return 0
    families = load_families()
    splits = {s: load_split(args.suite, s) for s in suite.splits if (suite_dir(args.suite) / f"{s}.jsonl").exists()}
    header = ("family", "variants", *splits, "example")
    rows = [header]
    for fid in suite.families:
        f = families[fid]
        counts = [str(sum(i.family == fid for i in insts)) for insts in splits.values()]
        rows.append((fid, ",".join(v.id for v in f.variants), *counts, f.variants[0].example))
    scenes = f"{', '.join(suite.scenes)} ({len(suite.scene_names())} scenes)"
    print(f"{suite.name}: {suite.description.strip()}\nscenes: {scenes}\n")
    print(_table(rows))
    _print_stats(splits)
    return 0


def _print_stats(splits: dict[str, list[Any]]) -> None:
    """Instances per capability (a tagged suite's) and optimal plan lengths per family, per split."""
    from robocog.agent.suitegen import stats

    everything = [i for insts in splits.values() for i in insts]
    capabilities = stats.per_capability(everything)
    if capabilities:
        rows = [("capability", *splits)]
        rows += [(c, *(str(stats.per_capability(insts).get(c, 0)) for insts in splits.values())) for c in capabilities]
        print("\n" + _table(rows))
    lengths = {name: stats.plan_lengths(insts) for name, insts in splits.items()}
    if everything:
        families = list(stats.plan_lengths(everything))
        rows = [("optimal plan (actions)", *(f"{s}: min / median / max" for s in splits))]
        for f in families:
            cells = [lengths[s].get(f) for s in splits]
            rows.append((f, *(f"{c.low} / {c.median:g} / {c.high}" if c else "-" for c in cells)))
        scenes = len(stats.scenes_used(everything))
        print("\n" + _table(rows) + f"\n\n{len(everything)} instances over {scenes} scenes")
