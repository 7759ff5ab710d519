"""Scale figures, offline, with the scripted models' latency model.

- Throughput: the planner on T1 with `latency_s=1.0` per model turn, `--workers N` (one server
  process per worker, as today) for N in 8, 16, 32, each worker running two units. Reported:
  attempts per minute once every worker's server is up (each attempt counted for the part of it
  that ran after that moment), against the ideal N x 60 / (turns x 1 s); the rate over the whole
  run, start-up included; and the servers' resident memory (the most seen while they worked).
- The Ray path: a small study (planner + overconfident, 2 trials, 2 memory iterations, T1 T2,
  2 workers) on a local one-node Ray cluster (`ray start --head` on loopback, started before the
  clock runs) against the same study run locally; goal <= 1.3x.

`python tests/bench/bench_scale.py [--only throughput|ray] [--workers 8,16,32]` runs them alone.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

from robocog.agent import evaluation
from robocog.agent.evaluation import Progress, read_rows, run_eval
from robocog.shared.evaluation import EvalConfig
from robocog.shared.trace import ModelTurn, read_trace

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import free_port

BIN = Path(sys.executable).parent
LATENCY_S = 1.0
WORKERS = (8, 16, 32)


def _study(**settings: Any) -> EvalConfig:
    return EvalConfig.model_validate({"name": "scale", **settings})


def _rss_mb(pids: list[int]) -> float:
    total = 0
    for pid in pids:
        with contextlib.suppress(OSError):
            for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
    return total / 1024


def _server_pids() -> list[int]:
    """The robocog-server processes this process spawned (its children)."""
    me = str(os.getpid())
    pids = []
    for status in Path("/proc").glob("[0-9]*/status"):
        with contextlib.suppress(OSError):
            fields = dict(line.split(":", 1) for line in status.read_text().splitlines() if ":" in line)
            if fields.get("PPid", "").strip() == me and "robocog" in Path(status.parent, "cmdline").read_text():
                pids.append(int(status.parent.name))
    return pids


def throughput(workers: int) -> dict[str, float]:
    """N workers, 2N units of one T1 attempt each, at LATENCY_S per model turn."""
    config = _study(
        models=[{"model": "scripted/planner", "params": {"latency_s": LATENCY_S}}],
        tasks=["T1"],
        trials=2 * workers,
        memory_iterations=1,
        workers=workers,
    )
    ready: list[float] = []
    finished: list[float] = []
    rss: list[float] = []
    real_connect = evaluation.connect

    @contextlib.asynccontextmanager
    async def timed_connect(spec: Any) -> AsyncIterator[Any]:
        async with real_connect(spec) as robot:
            ready.append(time.monotonic())
            yield robot

    def progress(p: Progress) -> None:
        if p.attempts > len(finished):
            finished.append(time.monotonic())
            if len(finished) % max(1, workers // 4) == 0:  # the servers' memory as they work
                rss.append(_rss_mb(_server_pids()))

    evaluation.connect = timed_connect
    try:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "r.jsonl"
            start = time.monotonic()
            asyncio.run(run_eval(config, out, workers=workers, on_progress=progress))
            end = time.monotonic()
            rows = read_rows(out)
            turns = [sum(isinstance(e, ModelTurn) for e in read_trace(out.parent / str(r.trace))) for r in rows]
    finally:
        evaluation.connect = real_connect
    up = max(ready)
    # Each attempt counts for the part of it that ran after every server was up.
    done = sum(
        min(1.0, max(0.0, (t - up) / r.wall_s)) if r.wall_s > 0 else 1.0 for t, r in zip(finished, rows, strict=True)
    )
    mean_turns = sum(turns) / len(turns)
    ideal = workers * 60 / (mean_turns * LATENCY_S)
    steady = done / (end - up) * 60
    key = f"scale.latency1s_{workers}_workers"
    return {
        f"{key}.attempts": len(rows),
        f"{key}.turns_per_attempt": round(mean_turns, 1),
        f"{key}.servers_up_s": round(up - start, 1),
        f"{key}.attempts_per_min": round(steady, 1),
        f"{key}.ideal_attempts_per_min": round(ideal, 1),
        f"{key}.fraction_of_ideal": round(steady / ideal, 2),
        f"{key}.attempts_per_min_with_startup": round(len(rows) / (end - start) * 60, 1),
        f"{key}.servers_peak_rss_mb": round(max(rss, default=0.0)),
        f"{key}.rss_per_server_mb": round(max(rss, default=0.0) / workers),
    }


@contextlib.contextmanager
def ray_cluster() -> Iterator[str]:
    """`ray start --head --block` on loopback with its own ports and directory; stopped with its group."""
    temp = Path(tempfile.mkdtemp(prefix="rc-ray-"))
    port = free_port()
    command = [
        *(str(BIN / "ray"), "start", "--head", "--block", "--node-ip-address", "127.0.0.1", "--port", str(port)),
        *("--num-cpus", "2", "--include-dashboard=false", "--disable-usage-stats", "--temp-dir", str(temp)),
        *("--ray-client-server-port", str(free_port()), "--dashboard-port", str(free_port())),
        *("--dashboard-agent-listen-port", str(free_port())),
    ]
    log = temp / "ray-start.log"
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    with log.open("w") as f:
        proc = subprocess.Popen(command, stdout=f, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while "Ray runtime started" not in log.read_text(errors="replace"):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("ray start failed:\n" + log.read_text(errors="replace")[-2000:])
            time.sleep(0.2)
        yield f"127.0.0.1:{port}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        shutil.rmtree(temp, ignore_errors=True)


def ray_overhead() -> dict[str, float]:
    config = _study(
        models=[{"model": "scripted/planner"}, {"model": "scripted/overconfident", "params": {"p": 0.5}}],
        tasks=["T1", "T2"],
        trials=2,
        memory_iterations=2,
        workers=2,
    )
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    rows_at: dict[str, list[float]] = {"local": [], "ray": []}

    def timed(name: str, **kwargs: Any) -> tuple[float, list[Any]]:
        def progress(p: Progress) -> None:
            if p.attempts > len(rows_at[name]):
                rows_at[name].append(time.monotonic() - start)

        start = time.monotonic()
        rows = asyncio.run(run_eval(config, Path(tmp) / f"{name}.jsonl", on_progress=progress, **kwargs))
        return time.monotonic() - start, rows

    with ray_cluster() as address, tempfile.TemporaryDirectory() as tmp:
        local, local_rows = timed("local")
        on_ray, ray_rows = timed("ray", ray_address=address)

    def outcome(rows: list[Any]) -> list[str]:
        return sorted(r.model_dump_json(exclude={"wall_s", "llm_latency_s", "trace"}) for r in rows)

    same = outcome(local_rows) == outcome(ray_rows)
    return {
        "scale.ray_study_attempts": len(ray_rows),
        "scale.ray_study_rows_identical": same,
        "scale.local_study_s": round(local, 1),
        "scale.ray_study_s": round(on_ray, 1),
        "scale.ray_overhead_x": round(on_ray / local, 2),
        # Start-up (to the first row: Ray's driver, the actors' processes, their servers) and the
        # rest (first row to last), apart: the start-up is paid once per study, the rest scales.
        "scale.local_first_row_s": round(rows_at["local"][0], 1),
        "scale.ray_first_row_s": round(rows_at["ray"][0], 1),
        "scale.ray_after_first_row_x": round(
            (rows_at["ray"][-1] - rows_at["ray"][0]) / (rows_at["local"][-1] - rows_at["local"][0]), 2
        ),
        "scale.ray_overhead_target_x": 1.3,
    }


def run(only: str = "", workers: tuple[int, ...] = WORKERS) -> dict[str, Any]:
    figures: dict[str, Any] = {}
    if only in ("", "throughput"):
        for n in workers:
            figures.update(throughput(n))
    if only in ("", "ray"):
        figures.update(ray_overhead())
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", choices=["throughput", "ray"], default="")
    parser.add_argument("--workers", default=",".join(map(str, WORKERS)))
    args = parser.parse_args()
    print(json.dumps(run(args.only, tuple(int(n) for n in args.workers.split(","))), indent=2))
