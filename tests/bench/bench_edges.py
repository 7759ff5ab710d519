"""Faults at the edges, as figures (issue 45):

- the time `robocog-server --scene FILE` takes to refuse each hostile scene (tests/hostile_scenes.py),
  from the process's start to its exit with status 2, beside `robocog-server --help`;
- the time `robocog run` takes to refuse a model LiteLLM does not know (`gpt4o`) and a cloud model
  whose key is not set (`gpt-4o` without OPENAI_API_KEY), beside `robocog --help`, in alternated rounds
  of the same run (medians);
- whether a live study's scratch memory survives a second study started in another PID namespace
  (`unshare --pid --fork --mount-proc`; "skipped" where it cannot run).

`make bench BENCH_ONLY=edges` runs it.
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.*
from tests.helpers import installed_env
from tests.hostile_scenes import write_all

BIN = Path(sys.executable).parent
ROUNDS = int(os.environ.get("BENCH_EDGES_ROUNDS", "5"))
#: No key of a cloud provider: a key-less model is refused as a first-time user meets it.
_KEYS = ("OPENAI_API_KEY", "ANTHROPIC_API_KEY")


def _timed(command: list[str], expect: int) -> float:
    env = {k: v for k, v in installed_env().items() if k not in _KEYS}
    t0 = time.perf_counter()
    done = subprocess.run(command, stdin=subprocess.DEVNULL, capture_output=True, text=True, env=env, timeout=600)
    took = time.perf_counter() - t0
    assert done.returncode == expect, (command, done.returncode, done.stderr[-2000:])
    if expect == 2:
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr  # one line
    return took


def _medians(commands: dict[str, tuple[list[str], int]]) -> dict[str, float]:
    """Each command's median wall time over alternated rounds (the machine's noise hits all alike)."""
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(ROUNDS):
        for name, (command, expect) in commands.items():
            times[name].append(_timed(command, expect))
    return {name: round(statistics.median(t), 3) for name, t in times.items()}


def _scenes() -> dict[str, Any]:
    server = str(BIN / "robocog-server")
    with tempfile.TemporaryDirectory() as tmp:
        hostile = write_all(Path(tmp))
        commands = {"server_help_s": ([server, "--help"], 0)}
        commands |= {
            f"refuse_scene.{name}_s": ([server, "--scene", str(path)], 2) for name, (path, _) in hostile.items()
        }
        return _medians(commands)


def _models() -> dict[str, Any]:
    robocog = str(BIN / "robocog")
    return _medians(
        {
            "robocog_help_s": ([robocog, "--help"], 0),
            "refuse_unknown_model_s": ([robocog, "run", "T1", "--model", "gpt4o"], 2),
            "refuse_keyless_model_s": ([robocog, "run", "T1", "--model", "gpt-4o"], 2),
        }
    )


_STUDY = """
import sys, time
from pathlib import Path
from robocog.agent.harness.scratch import memory_dir
with memory_dir(Path(sys.argv[1]), keep_memory=False) as path:
    print(path, flush=True)
    if sys.argv[2:] != ["brief"]:
        time.sleep(600)
"""


def _pid_namespace() -> dict[str, Any]:
    unshare = shutil.which("unshare")
    ns = [unshare or "unshare", "--pid", "--fork", "--mount-proc"]
    if unshare is None or subprocess.run([*ns, "true"], capture_output=True).returncode != 0:
        return {"study_survives_other_pid_namespace": "skipped"}
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "ROBOCOG_SCRATCH_DIR": tmp}
        work = str(Path(tmp) / "r.work")
        live = subprocess.Popen([sys.executable, "-c", _STUDY, work], stdout=subprocess.PIPE, text=True, env=env)
        try:
            assert live.stdout is not None
            path = Path(live.stdout.readline().strip())
            subprocess.run([*ns, sys.executable, "-c", _STUDY, work, "brief"], env=env, capture_output=True, check=True)
            survived = path.is_dir()
        finally:
            live.terminate()
            live.wait(timeout=60)
        return {"study_survives_other_pid_namespace": survived, "study_dir_removed_on_sigterm": not path.exists()}


def run() -> dict[str, Any]:
    figures = {**_scenes(), **_models(), **_pid_namespace()}
    return {f"edges.{key}": value for key, value in figures.items()}


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
