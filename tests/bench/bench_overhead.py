"""What an attempt costs beyond its physics: the marginal CPU of one scripted T1 attempt in a study
(harness and server processes together) divided by the CPU of the same physical actions (the tools
that act in the world or look at it, as the attempt called them) run in-process on a `World`, both
measured in the same run, at the same moments. The scripted planner's T1 is the paper's twelve
actions plus a drive to the TV and a grab of it that fails (it tries every object it is asked to put
away) and a last look around: the physics-only runs replay the attempt's own calls, read from the
study's first trace.

The marginal CPU is read inside one study of `1 + EXTRA` trials (`robocog eval` as a process, a
trial a unit): the CPU of the harness and its servers (every process of its tree, from /proc) when
the first attempt's row is written and when the last one's is, the difference over `EXTRA`. The
study's start-up (imports, servers, the embedding model) and its end are outside that window, so
their noise (seconds of CPU) does not divide into the figure; every unit's own work (its reset, its
memory namespace made and dropped, its verdict) is inside it. Averaged over `ROUNDS` measurements,
alternating with the other install's; over stdio (a server process per worker) and on a fleet (HTTP).

The physics-only CPU is measured by a process of its own running those actions again and again
while the study runs (the median of the runs that ended within the study's window): this machine's
speed drifts by a third within minutes and switches between two speeds for seconds at a time, so a
physics figure measured before or after a study can be a third off the study's own. The study (with
every process it starts) and the physics-only process are pinned to one and the same core (`CORE`):
each of this machine's two cores switches speed on its own, and a study on one core measured against
physics on the other read rounds from 1.51 to 1.84 over stdio, 1.69 to 2.19 on a fleet; on one core,
1.49 to 1.65 and 1.40 to 1.82 (docs/figures.md).

`ROBOCOG_BENCH_AGAINST=/path/to/other/.venv/bin` measures another install's studies too (the previous
release, say), alternating with this one's, against the same physics-only figure.

    python tests/bench/bench_overhead.py [--against /tmp/before/.venv/bin] [--extra 10]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import ROBOT_TOOLS
from robocog.server.world.world import World

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import installed_env

EXTRA = 10
#: How often the study's rows are looked at (the CPU is read when a row that marks the window appears).
POLL_S = 0.002
TICKS = os.sysconf("SC_CLK_TCK")
#: Rounds, each measuring every install's marginal CPU with the physics at the time (see `measure`).
ROUNDS = 6
ENV = installed_env()
#: The core the study and the physics-only runs share (the last one: the first takes most interrupts).
CORE = max(os.sched_getaffinity(0))


def _on_core() -> None:
    """In a child about to exec: run on `CORE` only (the children it starts inherit it)."""
    os.sched_setaffinity(0, {CORE})


#: The tools that act in the world or look at it: an attempt's physics, replayed by the physics-only runs.
PHYSICAL = frozenset({"look_around", "look", "move_to", "grab", "place", "open", "close"})


def physics_runs(actions: list[tuple[str, dict[str, Any]]], stop: Callable[[], bool]) -> Iterator[tuple[float, float]]:
    """`actions` (an attempt's physical tool calls, in its order) on an in-process world, from the
    paper's start, again and again until `stop()`: for each run, when it ended (time.time) and its
    CPU (its thread's). A failed action (the planner tries the TV, which cannot be grabbed) fails
    here as it did in the attempt."""
    tools = {t.name: t for t in ROBOT_TOOLS}
    world = World()
    robot = RobotSession(SessionConfig(), world=world)
    try:
        while not stop():
            world.reset()
            start = time.thread_time()
            for name, arguments in actions:
                robot.call(tools[name], **arguments)
            yield time.time(), time.thread_time() - start
    finally:
        world.close()


def attempt_actions(trace: Path) -> list[tuple[str, dict[str, Any]]]:
    """The physical tool calls of the attempt traced in `trace` (a JSONL trace), in their order."""
    events = [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()]
    return [(e["name"], e["arguments"]) for e in events if e["type"] == "tool_call" and e["name"] in PHYSICAL]


def _config(path: Path, trials: int, isolation: str) -> Path:
    config = {
        "name": "overhead",
        "models": [{"model": "scripted/planner"}],
        "tasks": ["T1"],
        "trials": trials,
        "memory_iterations": 1,
        "seed": 0,
        "workers": 1,
        "isolation": isolation,
    }
    if isolation == "fleet":
        config["fleet_processes"] = 1
    path.write_text(json.dumps(config), encoding="utf-8")  # YAML reads JSON
    return path


def _tree_cpu_s(root: int) -> float:
    """CPU seconds of process `root` and its descendants (each one's own and its reaped children's)."""
    stats: dict[int, list[str]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            with contextlib.suppress(OSError):
                text = Path(f"/proc/{entry}/stat").read_text()
                stats[int(entry)] = text[text.rindex(")") + 2 :].split()
    children: dict[int, list[int]] = {}
    for pid, fields in stats.items():
        children.setdefault(int(fields[1]), []).append(pid)
    total, todo = 0, [root]
    while todo:
        pid = todo.pop()
        if pid in stats:
            total += sum(int(v) for v in stats[pid][11:15])  # utime, stime, cutime, cstime
        todo += children.get(pid, [])
    return total / TICKS


def _thread_parts_s(root: int) -> dict[str, float]:
    """The CPU seconds of process `root` (the harness) and of its descendants (the servers), by part:
    the harness; a server's event loop (its main thread: the MCP stack, the transport, the tool
    wiring); a server's worker threads (the tool bodies: Python threads other than ChromaDB's); and
    the rest of a server's CPU, ChromaDB's native threads (tokio-*, sqlx-*; made and ended with its
    clients, so they are counted as the process's CPU less its live Python threads')."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            with contextlib.suppress(OSError):
                text = Path(f"/proc/{entry}/stat").read_text()
                parents[int(entry)] = int(text[text.rindex(")") + 2 :].split()[1])
    tree, todo = [], [root]
    while todo:
        pid = todo.pop()
        tree.append(pid)
        todo += [child for child, parent in parents.items() if parent == pid]
    parts = {"harness": 0.0, "server_loop": 0.0, "server_tools": 0.0, "chroma": 0.0}
    for pid in tree:
        with contextlib.suppress(OSError):  # a process that ended meanwhile
            total, python = _cpu_s(f"/proc/{pid}/stat"), {"server_loop": 0.0, "server_tools": 0.0}
            if pid == root:
                parts["harness"] += total
                continue
            for tid in os.listdir(f"/proc/{pid}/task"):
                with contextlib.suppress(OSError):
                    name = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
                    if not name.startswith(("tokio", "sqlx")):
                        python["server_loop" if int(tid) == pid else "server_tools"] += _cpu_s(
                            f"/proc/{pid}/task/{tid}/stat"
                        )
            for part, cpu in python.items():
                parts[part] += cpu
            parts["chroma"] += total - sum(python.values())
    return parts


def _cpu_s(stat: str) -> float:
    """utime + stime of a /proc stat file, in seconds."""
    text = Path(stat).read_text()
    fields = text[text.rindex(")") + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def attempt_cpu_s(
    bin_dir: Path, isolation: str, extra: int
) -> tuple[float, float, dict[str, float], list[tuple[str, dict[str, Any]]]]:
    """The CPU of one T1 attempt inside a study of `1 + extra` (`robocog eval` as a process), and the
    physics-only CPU of its physical actions at the same time: the CPU of the study and its servers from
    the moment the first attempt's row is written to the moment the last one's is, over `extra` (the
    study's start-up and end are outside that window); the median of the physics-only runs that a
    process of its own ended within that window (`--physics`); the attempt's CPU by part
    (`_thread_parts_s`); and the actions replayed."""
    with tempfile.TemporaryDirectory() as tmp:
        config, rows = _config(Path(tmp) / "study.yaml", 1 + extra, isolation), Path(tmp) / "rows.jsonl"
        marks: dict[int, tuple[float, float, dict[str, float]]] = {}  # rows written -> (time, CPU, by part)
        physics = subprocess.Popen(
            [sys.executable, __file__, "--physics"],
            preexec_fn=_on_core,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert physics.stdin is not None and physics.stdout is not None
        assert physics.stdout.readline().strip() == "ready"
        with subprocess.Popen(
            [str(bin_dir / "robocog"), "eval", str(config), "--out", str(rows), "--quiet"],
            preexec_fn=_on_core,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            env={**ENV, "ROBOCOG_DATA_DIR": f"{tmp}/memory"},
            cwd=tmp,
        ) as study:
            size = -1
            while study.poll() is None:
                if rows.exists() and rows.stat().st_size != size:  # a row written: count them
                    size = rows.stat().st_size
                    written = rows.read_bytes().count(b"\n")
                    if written in (1, 1 + extra) and written not in marks:
                        marks[written] = (time.time(), _tree_cpu_s(study.pid), _thread_parts_s(study.pid))
                        if written == 1:  # the physics-only runs replay the first attempt's actions
                            first = json.loads(rows.read_text(encoding="utf-8").splitlines()[0])
                            actions = attempt_actions(Path(tmp) / first["trace"])
                            physics.stdin.write(json.dumps(actions) + "\n")
                            physics.stdin.flush()
                time.sleep(POLL_S)
            error = study.stderr.read() if study.stderr else ""
        physics.terminate()
        ended = [json.loads(line) for line in physics.communicate()[0].splitlines()]
        if study.returncode != 0 or len(marks) != 2:
            raise RuntimeError(f"{bin_dir}: robocog eval ({isolation}, {1 + extra}) failed: {error[-800:]}")
        done = [json.loads(line) for line in rows.read_text(encoding="utf-8").splitlines()]
        if len(done) != 1 + extra or not all(r["true_success"] for r in done):
            raise RuntimeError(f"{bin_dir}: the study did not succeed on every trial: {done}")
    (start, first, parts_first), (end, last, parts_last) = marks[1], marks[1 + extra]
    within = [cpu for at, cpu in ended if start <= at <= end]
    if len(within) < 3:
        raise RuntimeError(f"only {len(within)} physics-only runs ended within the study's window")
    parts = {part: (cpu - parts_first.get(part, 0.0)) / extra for part, cpu in parts_last.items()}
    return (last - first) / extra, statistics.median(within), parts, actions


def measure(here: Path, against: Path | None, extra: int = EXTRA) -> dict[str, Any]:
    """Each round measures each install's attempt on stdio and on a fleet, alternately, each against
    the physics-only CPU measured at the same moments (this machine's speed drifts by a third within
    minutes and switches between two speeds for seconds at a time); the figures are the rounds' medians
    (a round caught by a switch moves a mean by a tenth)."""
    installs = [("", here)] + ([("against.", against)] if against is not None else [])
    physics: list[float] = []
    attempts: dict[str, list[float]] = {}
    ratios: dict[str, list[float]] = {}
    beyond: dict[str, list[float]] = {}  # the attempt's CPU less the physics-only CPU at the time
    parts: dict[str, dict[str, list[float]]] = {}
    for _ in range(ROUNDS):
        for isolation, name in (("process", "stdio"), ("fleet", "fleet")):
            for prefix, bin_dir in installs:
                attempt, at_the_time, by_part, actions = attempt_cpu_s(bin_dir, isolation, extra)
                physics.append(at_the_time)
                attempts.setdefault(f"{prefix}{name}", []).append(attempt)
                ratios.setdefault(f"{prefix}{name}", []).append(attempt / at_the_time)
                beyond.setdefault(f"{prefix}{name}", []).append(attempt - at_the_time)
                for part, cpu in by_part.items():
                    parts.setdefault(f"{prefix}{name}", {}).setdefault(part, []).append(cpu)
    out: dict[str, Any] = {
        "overhead.physics_cpu_s": round(statistics.median(physics), 3),
        "overhead.physics_cpu_s_runs": [round(v, 3) for v in physics],
    }
    for key, values in attempts.items():
        out[f"overhead.{key}.attempt_cpu_s"] = round(statistics.median(values), 3)
        out[f"overhead.{key}.attempt_cpu_s_runs"] = [round(v, 3) for v in values]
        out[f"overhead.{key}.ratio"] = round(statistics.median(ratios[key]), 2)
        out[f"overhead.{key}.ratio_runs"] = [round(v, 2) for v in ratios[key]]
        # the CPU an attempt spends besides its physical actions (the ratio less one, in ms)
        out[f"overhead.{key}.beyond_physics_ms"] = round(statistics.median(beyond[key]) * 1000, 1)
        for part, cpus in parts[key].items():  # where the attempt's CPU went (the tool bodies hold the physics)
            out[f"overhead.{key}.part.{part}_ms"] = round(statistics.median(cpus) * 1000, 1)
    out["overhead.target_ratio"] = 1.5
    out["overhead.physical_actions"] = len(actions)
    return out | unit_breakdown(actions)


#: What a unit of the study asks of its robot besides the model's physical actions, in its order (the
#: harness's calls and the planner's: `agent/harness/runner.py`, the planner's trace), by part.
_UNIT: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("reset", "reset_world", {"seed": 0, "memory_namespace": "overhead-unit", "search_k": 3}),
    ("memory", "clear_memory", {}),  # the harness asks it of the reset (contract 3.3): the same work
    ("other", "begin_task", {"task_id": "T1"}),
    ("memory", "search_memory", {"query": "Put away all the items into the shelf."}),
    ("other", "add_to_scratchpad", {"text": "Plan: the cube, the mug and the box to the shelf."}),
    ("physics", "", {}),  # the physical actions (two look arounds among them)
    ("memory", "end_task", {"status": "success", "description": "Put away all the items.", "summary": "Done."}),
    ("memory", "check_task", {"task_id": "T1", "record": False}),  # the unit's last: its namespace goes next
    ("memory", "clear_memory", {"drop": True}),
)


def unit_breakdown(actions: list[tuple[str, dict[str, Any]]], units: int = 8) -> dict[str, float]:
    """A unit's calls made in-process on a `RobotSession` (no MCP, no harness), with `actions` as its
    physics, CPU per part: what an attempt costs the server's tools themselves, and that over its
    physics (the floor of the ratio with any transport). The mean over `units` after a first. Its
    memory is where a study's servers keep theirs (in RAM where the machine has room: `scratch`)."""
    from robocog.agent.harness.scratch import scratch_root
    from robocog.server.tools import CONTROL_TOOLS

    tools = {t.name: t for t in (*ROBOT_TOOLS, *CONTROL_TOOLS)}
    parts: dict[str, float] = {}
    with tempfile.TemporaryDirectory(dir=scratch_root()) as tmp:
        robot = RobotSession(SessionConfig(data_dir=Path(tmp)))
        try:
            for unit in range(units + 1):
                for part, name, arguments in _UNIT:
                    calls = actions if part == "physics" else [(name, arguments)]
                    start = time.process_time()
                    for action, args in calls:
                        robot.call(tools[action], **args)
                    if unit > 0:
                        parts[part] = parts.get(part, 0.0) + time.process_time() - start
        finally:
            robot.world.close()
    out = {f"overhead.in_process.{part}_ms": round(cpu / units * 1000, 1) for part, cpu in parts.items()}
    out["overhead.in_process.ratio"] = round(sum(parts.values()) / parts["physics"], 2)
    return out


def run() -> dict[str, Any]:
    against = os.environ.get("ROBOCOG_BENCH_AGAINST")
    return measure(Path(sys.executable).parent, Path(against) if against else None)


def _physics_loop() -> None:
    """`--physics`: once the attempt's actions arrive on stdin (a JSON list of [tool, arguments]),
    physics-only runs of them until terminated, a JSON line [ended at, CPU] for each."""
    stopping = False

    def stop(*_: object) -> None:
        nonlocal stopping
        stopping = True

    signal.signal(signal.SIGTERM, stop)
    world = World()  # imports and the first world's derived files, before the study starts
    world.close()
    print("ready", flush=True)
    actions = [(name, arguments) for name, arguments in json.loads(sys.stdin.readline())]
    for ended, cpu in physics_runs(actions, lambda: stopping):
        print(json.dumps([ended, cpu]), flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", type=Path, help="another install's bin directory")
    parser.add_argument("--extra", type=int, default=EXTRA, help="trials beyond the first in the study")
    parser.add_argument("--physics", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.physics:
        _physics_loop()
    else:
        print(json.dumps(measure(Path(sys.executable).parent, args.against, args.extra), indent=2))
