"""Bad input on the command line: the real console scripts print one line, `PROGRAM: ...`, and exit 2.

Each case runs `robocog-server` or `robocog` as a subprocess, as a user would, and checks that
stderr is exactly one line naming the program, the file or option, and the problem: never a
traceback. Resuming a results file whose last line a crash tore is checked here too.
"""

from __future__ import annotations

import copy
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from robocog.agent.analysis.results_file import mend_torn_tail, read_rows
from robocog.server.world.world import DEFAULT_SCENE
from robocog.shared.evaluation import AttemptRow
from tests.helpers import free_port

BIN = Path(sys.executable).parent


def script(name: str) -> str:
    path = shutil.which(name, path=str(BIN))
    assert path is not None, f"{name} is not installed in {BIN}"
    return path


def one_line_error(program: str, *args: str | Path) -> str:
    """Run `program args`, expect exit 2 and one line on stderr; returns that line."""
    done = subprocess.run(
        [script(program), *map(str, args)], capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL
    )
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"{program}: ")
    return lines[0]


@pytest.fixture(scope="module")
def household() -> dict[str, Any]:
    data = yaml.safe_load(DEFAULT_SCENE.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def scene_file(tmp_path: Path, household: dict[str, Any], change: str) -> Path:
    """The shipped household with one defect."""
    data = copy.deepcopy(household)
    path = tmp_path / f"{change}.yaml"
    if change == "edge":
        data["edges"].append(["Front Door", "Attic"])
    elif change == "robot":
        data["robot"] = "robot/nowhere.yaml"
    elif change == "nan":
        data["locations"][1]["y"] = float("nan")
    elif change == "twice":
        data["objects"][1]["start"] = dict(data["objects"][0]["start"])
    if change == "latin1":
        path.write_bytes(b"name: caf\xe9\n")
    elif change == "syntax":
        path.write_text("name: x\nlocations: [{name: a, x: 0, y: 0}\n  edges: ]\n", encoding="utf-8")
    else:
        path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


EXPECTED = {
    "edge": "edges[8]: 'Attic' is not a location",
    "robot": "robot: 'robot/nowhere.yaml': no such file",
    "nan": "locations[1].y: must be a finite number, not NaN or infinity",
    "twice": "objects[1] (box): start position Front Door / floor is already taken by cube",
    "latin1": "line 1: not UTF-8 text (byte 0xe9); save the file as UTF-8",
    "syntax": "line 3, column 3: not valid YAML: expected ',' or ']', but got '<scalar>'",
}


# Each server start costs seconds: the other defects are checked in-process in test_scene.py.
@pytest.mark.parametrize("change", ["edge", "robot", "latin1", "syntax"])
def test_server_with_a_bad_scene_prints_one_line(tmp_path: Path, household: dict[str, Any], change: str) -> None:
    path = scene_file(tmp_path, household, change)
    line = one_line_error("robocog-server", "--scene", path)
    assert line.startswith(f"robocog-server: {path}: {EXPECTED[change]}")


def test_server_with_both_data_dir_and_memory_url_prints_one_line(tmp_path: Path) -> None:
    line = one_line_error("robocog-server", "--data-dir", tmp_path, "--memory-url", "http://127.0.0.1:8000")
    assert line.startswith("robocog-server: --data-dir and --memory-url cannot be used together")


@pytest.mark.parametrize(
    ("args", "problem"),
    [
        (["--robots", "4"], "--robots above 1 needs --transport http"),
        (["--robots", "4", "--transport", "http", "--max-sessions", "2"], "--max-sessions 2 is below --robots 4"),
        (["--robots", "2", "--transport", "http", "--view", "0"], "--view watches one robot"),
    ],
)
def test_a_fleet_with_options_it_cannot_honour_prints_one_line(args: list[str], problem: str) -> None:
    line = one_line_error("robocog-server", *args)
    assert problem in line


def study(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.yaml"
    path.write_text(text, encoding="utf-8")
    return path


GOOD_STUDY = "models: [{model: scripted/planner}]\ntrials: 1\nmemory_iterations: 1\nout: results.jsonl\n"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("models: [{model: scripted/planner}]\ntimeout_s: .nan\n", "timeout_s: must be a finite number"),
        ("models: [{model: scripted/planner}]\nrandomize: [1\n", "line 3, column 1: not valid YAML"),
        ("models: [{model: scripted/planner}]\ntrials: 0\n", "trials: Input should be greater than or equal to 1"),
        ("models: [{model: scripted/planner}\n", "line 2, column 1: not valid YAML"),
        ("models: []\nworkers: [1]\n", "models: List should have at least 1 item"),
    ],
)
def test_eval_with_a_bad_config_prints_one_line(tmp_path: Path, text: str, expected: str) -> None:
    path = study(tmp_path, text)
    assert one_line_error("robocog", "eval", path).startswith(f"robocog: {path}: {expected}")


def test_eval_with_a_non_utf8_config_prints_one_line(tmp_path: Path) -> None:
    path = tmp_path / "study.yaml"
    path.write_bytes(b"name: caf\xe9\nmodels: [{model: scripted/planner}]\n")
    line = one_line_error("robocog", "eval", path)
    assert line == f"robocog: {path}: line 1: not UTF-8 text (byte 0xe9); save the file as UTF-8"


def test_eval_checks_the_scene_its_servers_get(tmp_path: Path, household: dict[str, Any]) -> None:
    scene = scene_file(tmp_path, household, "edge")
    path = study(tmp_path, GOOD_STUDY + f"server_args: [--scene, {scene}]\n")
    assert one_line_error("robocog", "eval", path) == f"robocog: {scene}: {EXPECTED['edge']}"
    url = f"http://127.0.0.1:{free_port()}"  # nothing listens there
    path = study(tmp_path, GOOD_STUDY + f"server_args: [--memory-url, '{url}']\n")
    line = one_line_error("robocog", "eval", path)
    assert line.startswith(f"robocog: {path}: server_args: --memory-url {url}: no Chroma server answers there")


def test_eval_with_an_unwritable_results_file_prints_one_line(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("", encoding="utf-8")
    path = study(tmp_path, GOOD_STUDY.replace("out: results.jsonl", "out: file/results.jsonl"))
    line = one_line_error("robocog", "eval", path)
    assert line.startswith(f"robocog: {path}: out: cannot create {blocker}: ")


def test_report_of_a_broken_results_file_prints_one_line(tmp_path: Path) -> None:
    results = tmp_path / "results.jsonl"
    results.write_text('{"model": "x"}\n{"model": "y"}\n', encoding="utf-8")
    line = one_line_error("robocog", "report", results, "--out", tmp_path / "report")
    assert line == (
        f"robocog: {results}: not a results file of robocog eval (line 1: trial: Field required; "
        "memory_iteration: Field required; task: Field required; and 15 more)"
    )
    text = tmp_path / "notes.txt"  # a file that is not a results file at all: never "a torn last line"
    text.write_text("hello world\n", encoding="utf-8")
    line = one_line_error("robocog", "report", text, "--out", tmp_path / "report")
    assert (
        line
        == f"robocog: {text}: not a results file of robocog eval (line 1: not JSON: expected value at line 1 column 1)"
    )
    rows = tmp_path / "rows.jsonl"  # a results file with a foreign line in the middle
    rows.write_text(row(0).model_dump_json() + "\n[1, 2]\n" + row(1).model_dump_json() + "\n", encoding="utf-8")
    line = one_line_error("robocog", "report", rows, "--out", tmp_path / "report")
    assert line == f"robocog: {rows}: line 2 is not a result row (a JSON value that is not an object)"


@pytest.mark.parametrize(
    ("flag", "value", "problem"),
    [
        ("--trials", "0", "Input should be greater than or equal to 1"),
        ("--workers", "0", "Input should be greater than or equal to 1"),
        ("--workers", "-1", "Input should be greater than or equal to 1"),
        ("--memory-iterations", "-2", "Input should be greater than or equal to 1"),
    ],
)
def test_eval_overrides_are_validated_like_the_config(tmp_path: Path, flag: str, value: str, problem: str) -> None:
    path = study(tmp_path, GOOD_STUDY)
    assert one_line_error("robocog", "eval", path, flag, value) == f"robocog: {flag}: {problem}"
    assert not (tmp_path / "results.jsonl").exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--url", "http://127.0.0.1:9/mcp", "--data-dir", "/tmp/x"], "--url and --data-dir cannot be used together"),
        (
            ["--data-dir", "/tmp/x", "--server-cmd", "robocog-server --memory-url http://127.0.0.1:8000"],
            "--server-cmd: --memory-url cannot be used together with --data-dir",
        ),
        (["--max-steps", "0"], "--max-steps: must be at least 1, not 0"),
        (["--timeout", "nan"], "--timeout: must be a positive number of seconds, not nan"),
        (["--param", "p=Infinity"], "--param: p: must be a finite number, not Infinity"),
        (["--param", "nokey"], "--param: wants KEY=VALUE, got 'nokey'"),
    ],
)
def test_run_with_bad_options_prints_one_line(args: list[str], expected: str) -> None:
    assert one_line_error("robocog", "run", "T1", *args).startswith(f"robocog: {expected}")


def test_run_checks_the_scene_before_starting_a_server(tmp_path: Path, household: dict[str, Any]) -> None:
    scene = scene_file(tmp_path, household, "robot")
    line = one_line_error("robocog", "run", "T1", "--scene", scene)
    assert line.startswith(f"robocog: {scene}: {EXPECTED['robot']}")


# --- resume after a crash tore the last row ------------------------------------------------------


def row(trial: int) -> AttemptRow:
    return AttemptRow(
        model="planner",
        trial=trial,
        memory_iteration=0,
        task="T1",
        invocations=1,
        tool_calls=12,
        outcome="ended",
        believed_success=True,
        true_success=True,
        agreement=True,
        stopped=False,
        tokens_in=0,
        tokens_out=0,
        cost=None,
        llm_latency_s=0.0,
        wall_s=1.0,
        seed=trial,
        memory_labels="believed",
        trace=None,
        version="test",
    )


def test_a_torn_last_row_is_dropped_and_cut_before_appending(tmp_path: Path) -> None:
    out = tmp_path / "results.jsonl"
    whole = row(0).model_dump_json() + "\n"
    torn = row(1).model_dump_json()[:40]
    out.write_text(whole + torn, encoding="utf-8")
    assert read_rows(out) == [row(0)]
    mend_torn_tail(out)
    assert out.read_text(encoding="utf-8") == whole
    with out.open("a", encoding="utf-8") as f:  # as the resumed run appends the rerun attempt
        f.write(row(1).model_dump_json() + "\n")
    assert read_rows(out) == [row(0), row(1)]


def test_a_whole_last_row_without_its_newline_is_kept(tmp_path: Path) -> None:
    out = tmp_path / "results.jsonl"
    out.write_text(row(0).model_dump_json(), encoding="utf-8")
    mend_torn_tail(out)
    assert out.read_text(encoding="utf-8") == row(0).model_dump_json() + "\n"
    assert read_rows(out) == [row(0)]


def test_eval_into_a_file_that_holds_results_is_one_line_and_draws_no_bar(tmp_path: Path) -> None:
    path = study(tmp_path, GOOD_STUDY)
    (tmp_path / "results.jsonl").write_text(row(0).model_dump_json() + "\n", encoding="utf-8")
    done = subprocess.run(
        [script("robocog"), "eval", str(path)], capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL
    )
    assert done.returncode == 2, done.stderr
    expected = (
        f"robocog: {tmp_path / 'results.jsonl'} already holds 1 results: use --resume to continue, or another --out"
    )
    assert done.stderr.splitlines() == [expected]
    assert done.stdout == ""  # no progress bar, empty or not


def test_eval_with_a_model_whose_key_is_missing_draws_no_bar(tmp_path: Path) -> None:
    path = study(tmp_path, GOOD_STUDY.replace("scripted/planner", "gpt-4o"))
    env = {k: v for k, v in os.environ.items() if k != "OPENAI_API_KEY"}
    done = subprocess.run([script("robocog"), "eval", str(path)], capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        "robocog: model 'gpt-4o' needs OPENAI_API_KEY set in the environment (or give --api-key)"
    ]
    assert done.stdout == ""


@pytest.mark.parametrize(
    ("program", "args", "expected"),
    [
        (
            "robocog-server",
            ["--observe", "bogus"],
            "robocog-server: error: argument --observe: invalid choice: 'bogus' (choose from 'location', 'room', "
            "'house'); see robocog-server --help",
        ),
        ("robocog", ["run"], "robocog run: error: the following arguments are required: TASK; see robocog run --help"),
        (
            "robocog",
            ["eval", "s.yaml", "--bogus"],
            "robocog: error: unrecognized arguments: --bogus; see robocog --help",
        ),
    ],
)
def test_a_usage_error_is_one_line_without_the_usage_block(program: str, args: list[str], expected: str) -> None:
    done = subprocess.run([script(program), *args], capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stderr.splitlines(), done.stdout) == (2, [expected], "")
