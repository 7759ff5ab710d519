"""Start-up figures, whole processes: `robocog --help`, `robocog-server` spawned to its first
`tools/list` answer (stdio), and `robocog run T1 --model scripted/planner`.

The machine's speed drifts from hour to hour, so a figure means something only beside another
install measured at the same moment: `ROBOCOG_BENCH_AGAINST=/path/to/other/.venv/bin` (an install
of the previous release, say) measures both, alternating run by run, and reports each and their
ratio. Without it, only this install.

    python tests/bench/bench_startup.py --against /tmp/before/.venv/bin
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import installed_env

RUNS = 5
ENV = installed_env()
#: initialize, initialized, tools/list: the first answer a host waits for, on any protocol version
#: the server takes (2025-06-18 here: every release of robocog's server speaks it).
HANDSHAKE = "\n".join(
    json.dumps(m)
    for m in (
        {
            "jsonrpc": "2.0",
            "id": 1,
            "method": "initialize",
            "params": {
                "protocolVersion": "2025-06-18",
                "capabilities": {},
                "clientInfo": {"name": "bench", "version": "0"},
            },
        },
        {"jsonrpc": "2.0", "method": "notifications/initialized"},
        {"jsonrpc": "2.0", "id": 2, "method": "tools/list"},
    )
)


def _help(bin_dir: Path) -> float:
    start = time.perf_counter()
    subprocess.run([str(bin_dir / "robocog"), "--help"], capture_output=True, check=True, env=ENV, timeout=60)
    return time.perf_counter() - start


def _server_first_tools_list(bin_dir: Path) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        proc = subprocess.Popen(
            [str(bin_dir / "robocog-server"), "--data-dir", f"{tmp}/memory"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=ENV,
            text=True,
        )
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(HANDSHAKE + "\n")
        proc.stdin.flush()
        for line in proc.stdout:
            if json.loads(line).get("id") == 2:
                break
        took = time.perf_counter() - start
        proc.stdin.close()
        proc.wait(timeout=30)
        return took


def _run_t1(bin_dir: Path) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        command = [str(bin_dir / "robocog"), "run", "T1", "--model", "scripted/planner", "--quiet"]
        done = subprocess.run(
            [*command, "--data-dir", f"{tmp}/memory"], capture_output=True, text=True, env=ENV, timeout=180
        )
        if done.returncode != 0:
            raise RuntimeError(f"{bin_dir}: robocog run T1 failed: {done.stderr[-500:]}")
        return time.perf_counter() - start


FIGURES: dict[str, Callable[[Path], float]] = {
    "help_s": _help,
    "server_first_tools_list_s": _server_first_tools_list,
    "run_t1_s": _run_t1,
}


def measure(here: Path, against: Path | None, runs: int = RUNS) -> dict[str, float]:
    """Each figure's median over `runs`, for this install and (alternating) the other one."""
    out: dict[str, float] = {}
    for name, figure in FIGURES.items():
        figure(here)  # one warm-up each: the page cache, bytecode
        if against is not None:
            figure(against)
        mine: list[float] = []
        theirs: list[float] = []
        for _ in range(runs):
            mine.append(figure(here))
            if against is not None:
                theirs.append(figure(against))
        out[f"startup.{name}"] = round(statistics.median(mine), 3)
        if against is not None:
            out[f"startup.against.{name}"] = round(statistics.median(theirs), 3)
            out[f"startup.ratio.{name}"] = round(statistics.median(mine) / statistics.median(theirs), 2)
    return out


def run() -> dict[str, float]:
    against = os.environ.get("ROBOCOG_BENCH_AGAINST")
    return measure(Path(sys.executable).parent, Path(against) if against else None)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", type=Path, help="another install's bin directory, measured alternately")
    parser.add_argument("--runs", type=int, default=RUNS)
    args = parser.parse_args()
    print(json.dumps(measure(Path(sys.executable).parent, args.against, args.runs), indent=2))
