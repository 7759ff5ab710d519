"""`make bench`: run every benchmark in tests/bench and print one JSON object of figures.

Each `bench_*.py` module here has `run() -> dict`; `--only world,memory` picks some. `--record`
merges the figures into docs/figures.json, the one place the docs read them from (`[[fig:KEY]]` in a
page; docs/hooks/figures.py), each with the day it was measured. A module with `NAMED_ONLY = True`
runs only when `--only` names it (the local model's bench: about 90 minutes, `make local-model`).
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import os
import platform
import sys
import time
from pathlib import Path

from robocog.server.world.cstdio import stdout_to_stderr

HERE = Path(__file__).resolve().parent
RECORD = HERE.parents[1] / "docs" / "figures.json"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", default="", help="comma-separated benchmark names, e.g. world,server")
    parser.add_argument("--record", action="store_true", help=f"merge the figures into {RECORD.name}")
    args = parser.parse_args()
    wanted = {n.strip() for n in args.only.split(",") if n.strip()}
    figures: dict[str, object] = {}
    with stdout_to_stderr():  # C code (PyBullet) prints on stdout; stdout is for the JSON
        collect(wanted, figures)
    print(json.dumps(figures, indent=2))
    if args.record:
        record(figures, RECORD)
        print(f"bench: {len(figures)} figures recorded in {RECORD}", file=sys.stderr)
    return 0


def record(figures: dict[str, object], path: Path) -> None:
    """Merge `figures` into the recorded ones (a figure measured again replaces its old value)."""
    kept = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {"figures": {}}
    today = datetime.date.today().isoformat()
    for key, value in figures.items():
        kept["figures"][key] = {"value": value, "date": today}
    kept["machine"] = f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    kept["figures"] = dict(sorted(kept["figures"].items()))
    path.write_text(json.dumps(kept, indent=1) + "\n", encoding="utf-8")


def collect(wanted: set[str], figures: dict[str, object]) -> None:
    for path in sorted(HERE.glob("bench_*.py")):
        name = path.stem.removeprefix("bench_")
        if wanted and name not in wanted:
            continue
        spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        if not wanted and getattr(module, "NAMED_ONLY", False):
            print(f"bench: {name} runs only when named (--only {name})", file=sys.stderr)
            continue
        start = time.perf_counter()
        print(f"bench: {name} ...", file=sys.stderr, flush=True)
        figures.update(module.run())
        figures[f"{name}.bench_wall_s"] = round(time.perf_counter() - start, 2)


if __name__ == "__main__":
    sys.exit(main())
