"""Fresh splits written into their cache (`robocog.shared.seeded_splits`): a split generated from a
seed, the bytes `robocog suite generate --split SPLIT --seed SEED` writes, beside a copy of the
suite's manifest (what a server reads of it)."""

from __future__ import annotations

import os
import shutil
import sys
import time
from pathlib import Path

from robocog.shared.seeded_splits import split_file
from robocog.shared.suite import dump_instances, load_suite, suite_dir


def generate_into(suite: str, split: str, seed: int, root: Path) -> Path:
    """Generate `split@seed` of `suite` (a name or a directory) into the cache root `root`, atomically
    (a concurrent writer of the same split writes the same bytes); returns the file."""
    from robocog.agent.suitegen.generator import generate

    manifest = load_suite(suite)
    out = split_file(root, manifest.name, split, seed)
    out.parent.mkdir(parents=True, exist_ok=True)
    # said first: a large split takes minutes (robocog-v2.1's test split: about 2 on 2 cores), once
    print(f"robocog: generating {manifest.name} {split}@{seed} from its seed (once: cached in {root})", file=sys.stderr)
    started = time.perf_counter()
    workers = max(1, min(4, os.cpu_count() or 1))
    text = dump_instances(generate(manifest, split, seed=seed, workers=workers, directory=suite_dir(suite)))
    shutil.copyfile(suite_dir(suite) / "suite.yaml", out.parent / f"suite.yaml.{os.getpid()}")
    os.replace(out.parent / f"suite.yaml.{os.getpid()}", out.parent / "suite.yaml")
    partial = out.with_name(f"{out.name}.{os.getpid()}")
    partial.write_bytes(text.encode("utf-8"))
    os.replace(partial, out)
    seconds = time.perf_counter() - started
    count = text.count("\n")
    print(f"robocog: generated {manifest.name} {split}@{seed}: {count} instances in {seconds:.1f} s", file=sys.stderr)
    return out
