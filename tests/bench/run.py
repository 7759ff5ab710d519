"""`make bench`: run every benchmark in tests/bench and print one JSON object of figures.

Each `bench_*.py` module here has `run() -> dict`; `--only world,memory` picks some.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path

from robocog.server.world.cstdio import stdout_to_stderr

HERE = Path(__file__).resolve().parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", default="", help="comma-separated benchmark names, e.g. world,server")
    args = parser.parse_args()
    wanted = {n.strip() for n in args.only.split(",") if n.strip()}
    figures: dict[str, object] = {}
    with stdout_to_stderr():  # C code (PyBullet) prints on stdout; stdout is for the JSON
        collect(wanted, figures)
    print(json.dumps(figures, indent=2))
    return 0


def collect(wanted: set[str], figures: dict[str, object]) -> None:
    for path in sorted(HERE.glob("bench_*.py")):
        name = path.stem.removeprefix("bench_")
        if wanted and name not in wanted:
            continue
        spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        start = time.perf_counter()
        print(f"bench: {name} ...", file=sys.stderr, flush=True)
        figures.update(module.run())
        figures[f"{name}.bench_wall_s"] = round(time.perf_counter() - start, 2)


if __name__ == "__main__":
    sys.exit(main())
