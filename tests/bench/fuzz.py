"""`make fuzz`: attack real `robocog-server --profile eval` processes and print the figures as JSON.

Stdio: `--calls` (25,000) random and hostile calls, one at a time, written as raw JSON-RPC lines so
that anything can be sent: valid actions, hostile arguments of every type (texts of up to 10 MB,
control characters, lone surrogates, huge numbers, NaN, deep nesting), unknown tools and methods,
odd resource URIs, random resets, begin_task and end_task, and lines that are not JSON-RPC at all.
After every call the world's ground truth (robocog://world/state) is checked against the invariants
of tests/world_invariants.py; a dead server is counted and started again. Per call: the wall time, and the
server's CPU time (utime + stime of /proc/PID/stat, all its threads) from sending to the answer.
RSS (VmRSS) is sampled every 1,000 calls.

HTTP: `--http-clients` (32) MCP clients at once, `--http-calls` (50) read-only calls each, against
`robocog-server --transport http` on a free loopback port: errors, p50/p99.

Not in `make bench` (which runs tests/bench/bench_*.py): 25,000 calls take minutes.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from robocog.server.world.cstdio import stdout_to_stderr  # noqa: E402
from tests.bench.fuzz_http import fuzz_http  # noqa: E402
from tests.bench.fuzz_stdio import fuzz_stdio  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calls", type=int, default=25_000, help="hostile calls over stdio (default: 25000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the calls' random generator (default: 0)")
    parser.add_argument("--http-clients", type=int, default=32, help="HTTP clients at once (default: 32)")
    parser.add_argument("--http-calls", type=int, default=50, help="calls per HTTP client (default: 50)")
    parser.add_argument("--only", choices=["stdio", "http"], default=None, help="run one of the two")
    args = parser.parse_args()
    if args.calls < 1000 or args.http_clients < 1 or args.http_calls < 1:
        parser.error("--calls must be at least 1000 (RSS is sampled every 1000), the HTTP counts at least 1")
    figures: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp, stdout_to_stderr():
        work = Path(tmp)
        if args.only in (None, "stdio"):
            started = time.perf_counter()
            figures |= fuzz_stdio(args.calls, args.seed, work)
            figures["fuzz.wall_s"] = round(time.perf_counter() - started, 1)
        if args.only in (None, "http"):
            figures |= fuzz_http(args.http_clients, args.http_calls, work)
    print(json.dumps(figures, indent=2, ensure_ascii=False))
    return 0 if not (figures.get("fuzz.server_deaths") or figures.get("fuzz.invariant_violations")) else 1


if __name__ == "__main__":
    sys.exit(main())
