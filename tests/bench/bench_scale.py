"""Scale figures, offline, with the scripted models' latency model.

- A fleet's memory: one `robocog-server --robots 64` process, its RSS as 1, 2, 4, ... 64 sessions
  each take a robot; per additional robot (goal <= 30 MB) and for 64 robots (goal <= 2.5 GB). And
  where a robot's memory goes, each part measured in a fresh process (`robot_memory.py`): PyBullet's
  empty client, the floor and the arm as they were built and as they are, a whole world, a robot;
  and the arm drawn with both visual meshes (docs/arm-visuals.png).
- `ROBOCOG_BENCH_AGAINST=/path/to/other/.venv/bin` measures another install's fleet memory and its
  64 workers on fleets too (the previous release), right after this one's, as `scale.against.*`.
- Throughput: the planner on T1 with `latency_s=1.0` per model turn, `--workers N`, each worker
  running two units: 16 workers with a server process each (`isolation: process`), and 16 and 64
  workers on fleets (`isolation: fleet`, a fleet per core). Reported:
  attempts per minute once every worker's server is up (each attempt counted for the part of it
  that ran after that moment), against the ideal N x 60 / (turns x 1 s); the rate over the whole
  run, start-up included; and the servers' resident memory (the most seen while they worked).
- A scripted study without latency (planner + overconfident, T1 T2) on fleets with 1 and 2 workers,
  and with 2 server processes: the speedup of the second worker.
- The Ray path: a small study (planner + overconfident, 2 trials, 2 memory iterations, T1 T2,
  2 workers) on a local one-node Ray cluster (`ray start --head` on loopback, started before the
  clock runs) against the same study run locally; goal <= 1.3x.

`python tests/bench/bench_scale.py [--only fleet|throughput|speedup|ray] [--record]` runs them alone
(`--record` merges the figures into docs/figures.json, as `tests/bench/run.py --record` does).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.agent.analysis.results_file import read_rows
from robocog.agent.harness import runner as evaluation
from robocog.agent.harness.study import run_eval
from robocog.shared.evaluation import EvalConfig
from robocog.shared.trace import ModelTurn, read_trace

if TYPE_CHECKING:  # a type only: `against` runs this file under an older install, which keeps it elsewhere
    from robocog.agent.harness.progress import Progress

BIN = Path(sys.executable).parent
LATENCY_S = 1.0
#: (isolation, workers) of the throughput runs.
THROUGHPUT = (("process", 16), ("fleet", 16), ("fleet", 64))
#: Runs of 64 workers on fleets (each alternating with the other install's, when one is given).
THROUGHPUT_ROUNDS = 2
FLEET_ROBOTS = 64


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


def fleet_memory() -> dict[str, float]:
    """One fleet server; its RSS as more and more sessions each take a robot (a look_around)."""
    from mcp import Client
    from mcp.client.streamable_http import streamable_http_client

    from tests.helpers import http_server

    figures: dict[str, float] = {}

    async def grow(url: str, pid: int) -> None:
        async with contextlib.AsyncExitStack() as stack:
            clients: list[Any] = []
            for n in (1, 2, 4, 8, 16, 32, 64):
                while len(clients) < n:
                    client = await stack.enter_async_context(Client(streamable_http_client(url), mode="legacy"))
                    result = await client.call_tool("look_around", {})
                    assert not result.is_error, result.content
                    clients.append(client)
                figures[f"scale.fleet_rss_{n}_robots_mb"] = round(_rss_mb([pid]), 1)

    with tempfile.TemporaryDirectory() as tmp:
        args = ["--robots", str(FLEET_ROBOTS), "--max-sessions", str(FLEET_ROBOTS + 4), "--data-dir", f"{tmp}/m"]
        with http_server(Path(tmp) / "fleet.log", *args) as url:
            time.sleep(3)  # the first robot and the embedding model are built in the background
            pid = max(_server_pids())
            figures["scale.fleet_rss_idle_mb"] = round(_rss_mb([pid]), 1)
            asyncio.run(grow(url, pid))
    one, all_ = figures["scale.fleet_rss_1_robots_mb"], figures[f"scale.fleet_rss_{FLEET_ROBOTS}_robots_mb"]
    figures["scale.fleet_rss_per_extra_robot_mb"] = round((all_ - one) / (FLEET_ROBOTS - 1), 1)
    figures["scale.fleet_rss_per_extra_robot_target_mb"] = 30
    figures["scale.fleet_rss_64_robots_target_mb"] = 2560
    return figures


def robot_breakdown() -> dict[str, float]:
    """MB per robot of each part (`robot_memory.py`), each in a process of its own."""
    from tests.bench.robot_memory import PARTS

    parts: dict[str, float] = {}
    for part in PARTS:
        done = subprocess.run(
            [sys.executable, str(Path(__file__).with_name("robot_memory.py")), part],
            capture_output=True,
            text=True,
            timeout=300,
            check=True,
        )
        parts.update(json.loads(done.stdout.strip().splitlines()[-1]))
    arms = Path(__file__).resolve().parents[2] / "docs" / "arm-visuals.png"
    subprocess.run(
        [sys.executable, str(Path(__file__).with_name("robot_memory.py")), "--figure", str(arms)], check=True
    )
    figures = {f"scale.robot_mb.{part}": mb for part, mb in parts.items()}
    # What the world adds to PyBullet's empty client (the arm, its visual meshes simplified, is most
    # of it); and what a robot adds to its world (its session, the first frame).
    figures["scale.robot_mb.scene"] = round(parts["world"] - parts["client"], 2)
    figures["scale.robot_mb.session"] = round(parts["robot"] - parts["world"], 2)
    figures["scale.robot_mb.saved"] = round(parts["world_original"] - parts["world"], 2)
    figures["scale.robot_mb.client_share"] = round(parts["client"] / parts["robot"], 2)
    return figures


def speedup() -> dict[str, float]:
    """A scripted study without latency, with 1 and 2 workers: on fleets, and on server processes."""
    from robocog.agent.client.model import warm_up_litellm

    warm_up_litellm(["scripted/planner"])  # LiteLLM's import (seconds) is not the first run's
    times: dict[str, float] = {}
    for isolation, workers in (("fleet", 1), ("fleet", 2), ("process", 1), ("process", 2)):
        config = _study(
            models=[{"model": "scripted/planner"}, {"model": "scripted/overconfident", "params": {"p": 0.3}}],
            tasks=["T1", "T2"],
            trials=4,
            memory_iterations=2,
            workers=workers,
            isolation=isolation,
        )
        with tempfile.TemporaryDirectory() as tmp:
            start = time.monotonic()
            asyncio.run(run_eval(config, Path(tmp) / "r.jsonl"))
            times[f"{isolation}_{workers}"] = time.monotonic() - start
    return {
        "scale.study_fleet_1_worker_s": round(times["fleet_1"], 1),
        "scale.study_fleet_2_workers_s": round(times["fleet_2"], 1),
        "scale.study_fleet_speedup_2_workers": round(times["fleet_1"] / times["fleet_2"], 2),
        "scale.study_process_1_worker_s": round(times["process_1"], 1),
        "scale.study_process_2_workers_s": round(times["process_2"], 1),
        "scale.study_process_speedup_2_workers": round(times["process_1"] / times["process_2"], 2),
    }


def throughput(isolation: str, workers: int, processes: int | None = None, label: str = "") -> dict[str, float]:
    """N workers, 2N units of one T1 attempt each, at LATENCY_S per model turn (on `processes`
    fleets if given, else the harness's default; `label` goes into the figures' names)."""
    fleets = {"fleet_processes": processes} if processes is not None else {}
    config = _study(
        **fleets,
        models=[{"model": "scripted/planner", "params": {"latency_s": LATENCY_S}}],
        tasks=["T1"],
        trials=2 * workers,
        memory_iterations=1,
        workers=workers,
        isolation=isolation,
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
    cpu_before = _cpu_s()
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
    harness_cpu, servers_cpu = (after - before for after, before in zip(_cpu_s(), cpu_before, strict=True))
    mean_turns = sum(turns) / len(turns)
    ideal = workers * 60 / (mean_turns * LATENCY_S)
    steady = done / (end - up) * 60
    # The most this machine's cores could run, given the CPU an attempt took (harness + servers).
    cpu_per_attempt = (harness_cpu + servers_cpu) / len(rows)
    cpu_ceiling = (os.cpu_count() or 1) * 60 / cpu_per_attempt
    key = f"scale.latency1s_{isolation}_{workers}_workers{label}"
    return {
        f"{key}.attempts": len(rows),
        f"{key}.turns_per_attempt": round(mean_turns, 1),
        f"{key}.servers_up_s": round(up - start, 1),
        f"{key}.attempts_per_min": round(steady, 1),
        f"{key}.ideal_attempts_per_min": round(ideal, 1),
        f"{key}.fraction_of_ideal": round(steady / ideal, 2),
        f"{key}.attempts_per_min_with_startup": round(len(rows) / (end - start) * 60, 1),
        f"{key}.servers_peak_rss_mb": round(max(rss, default=0.0)),
        f"{key}.rss_per_worker_mb": round(max(rss, default=0.0) / workers),
        f"{key}.harness_cpu_s_per_attempt": round(harness_cpu / len(rows), 2),
        f"{key}.servers_cpu_s_per_attempt": round(servers_cpu / len(rows), 2),
        f"{key}.cpu_bound_attempts_per_min": round(cpu_ceiling, 1),
    }


def _cpu_s() -> tuple[float, float]:
    """CPU seconds used so far by this process (the harness) and by its children that have ended."""
    me, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime, children.ru_utime + children.ru_stime


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

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
    from tests.helpers import ray_cluster  # here: `against` runs this file under an install without it

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


def _mean(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The runs' figures averaged (the fraction of the ideal also run by run, as `...fraction_runs`)."""
    if not runs or not runs[0]:
        return {}
    out: dict[str, Any] = {key: round(sum(r[key] for r in runs) / len(runs), 2) for key in runs[0]}
    for key in [k for k in runs[0] if k.endswith(".fraction_of_ideal")]:
        out[key.removesuffix("of_ideal") + "runs"] = [r[key] for r in runs]
    return out


def against(only: str) -> dict[str, Any]:
    """The same figures from another install (`ROBOCOG_BENCH_AGAINST=/its/.venv/bin`: the previous
    release), measured right after this one's, under `scale.against.`; nothing when it is not set."""
    bin_dir = os.environ.get("ROBOCOG_BENCH_AGAINST")
    if not bin_dir:
        return {}
    done = subprocess.run(
        [str(Path(bin_dir) / "python"), __file__, "--only", only],
        capture_output=True,
        text=True,
        timeout=3600,
        cwd=tempfile.gettempdir(),
    )
    if done.returncode != 0:
        raise RuntimeError(f"{bin_dir}: bench_scale --only {only} failed: {done.stderr[-800:]}")
    # PyBullet prints its build time on stdout: the figures are the JSON object after it.
    start = 0 if done.stdout.startswith("{") else done.stdout.index("\n{") + 1
    figures = json.loads(done.stdout[start:])
    return {key.replace("scale.", "scale.against.", 1): value for key, value in figures.items()}


def run(only: str = "") -> dict[str, Any]:
    figures: dict[str, Any] = {}
    if only in ("", "fleet"):
        figures.update(fleet_memory())
        figures.update(against("fleet_rss"))
        figures.update(robot_breakdown())
    if only == "fleet_rss":  # the previous release's side of the comparison (see `against`)
        figures.update(fleet_memory())
    if only == "throughput64":  # the previous release's side of the comparison (see `against`)
        figures.update(throughput("fleet", 64))
    if only in ("", "throughput"):
        for isolation, n in THROUGHPUT:
            if (isolation, n) != ("fleet", 64):
                figures.update(throughput(isolation, n))
        # 64 on fleets, this install and the other alternately, twice: one run moves by +-0.05 here
        runs = [(throughput("fleet", 64), against("throughput64")) for _ in range(THROUGHPUT_ROUNDS)]
        figures.update(_mean([ours for ours, _ in runs]))
        figures.update(_mean([theirs for _, theirs in runs]))
        # The same on one fleet per core, as the harness ran it before the fleets grew with the workers.
        figures.update(throughput("fleet", 64, processes=os.cpu_count() or 1, label="_a_fleet_per_core"))
    if only in ("", "speedup"):
        figures.update(speedup())
    if only in ("", "ray"):
        figures.update(ray_overhead())
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parts = ["fleet", "fleet_rss", "throughput", "throughput64", "speedup", "ray"]
    parser.add_argument("--only", choices=parts, default="")
    parser.add_argument("--record", action="store_true", help="merge the figures into docs/figures.json")
    args = parser.parse_args()
    measured = run(args.only)
    print(json.dumps(measured, indent=2))
    if args.record:
        from tests.bench.run import RECORD, record

        record(measured, RECORD)
