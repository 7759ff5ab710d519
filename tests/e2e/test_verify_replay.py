"""Verified by replay (`robocog submit verify`): a submission's attempts replayed in the physics of a
real server process from their own traces. The policy is not ours: a fixed sequence of tool calls
(the `replay/` model over a hand-written trace: it looks, grabs a cube, tries a teapot that does not
exist, puts the cube and the box on the shelf, forgets the mug and claims success), so nothing of
robocog's planner decides what the agent did. An honest submission verifies; one whose
`true_success` was edited (its digest recomputed, so `validate` passes) fails, naming the attempt;
the leaderboard marks it."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.agent.analysis.results_file import read_rows
from robocog.agent.cli.main import main
from robocog.shared.provenance import sha256_of
from tests.e2e.test_bundle import eval_study

#: The fixed policy's calls: a false claim of success (the mug stays on the table), with a hallucinated object.
CALLS: tuple[tuple[str, dict[str, object]], ...] = (
    ("look_around", {}),
    ("grab", {"object": "cube"}),
    ("move_to", {"location": "Kitchen Shelf"}),
    ("place", {"location": "Kitchen Shelf", "position": "top"}),
    ("grab", {"object": "teapot"}),
    ("move_to", {"location": "Living Room"}),
    ("grab", {"object": "box"}),
    ("move_to", {"location": "Kitchen Shelf"}),
    ("place", {"location": "Kitchen Shelf", "position": "middle"}),
    ("end_task", {"status": "success", "description": "put away", "summary": "everything is on the shelf"}),
)


def fixed_policy(path: Path) -> Path:
    """A trace of model turns that the `replay/` model answers in order: the fixed policy."""
    lines = []
    for step, (name, arguments) in enumerate(CALLS, 1):
        call = {
            "id": f"call_{step}",
            "type": "function",
            "function": {"name": name, "arguments": json.dumps(arguments)},
        }
        message = {"role": "assistant", "content": None, "tool_calls": [call]}
        turn = {"t": 0.0, "type": "model_turn", "invocation": 1, "step": step, "message": message, "latency_s": 0.0}
        lines.append(json.dumps(turn))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def submission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The fixed policy's study on T1 (2 trials), packed by `robocog submit prepare`."""
    folder = tmp_path_factory.mktemp("fixed")
    policy = fixed_policy(folder / "policy.jsonl")
    config = folder / "study.yaml"
    config.write_text(
        f"name: fixed\nmodels:\n  - {{model: 'replay/{policy}', label: fixed}}\n"
        "tasks: [T1]\ntrials: 2\nmemory_iterations: 1\nseed: 0\nworkers: 1\n"
    )
    results = eval_study(folder / "results" / "fixed.jsonl", config=config)
    rows = read_rows(results)
    assert [(r.believed_success, r.true_success, r.robot_actions) for r in rows] == [(True, False, 8)] * 2
    out = folder / "submission.json"
    assert main(["submit", "prepare", str(results), "--out", str(out)]) == 0
    return out


def verify(path: Path) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "robocog.agent.cli", "submit", "verify", str(path)]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


def test_a_submission_carries_its_traces_with_their_digests(
    submission: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = json.loads(submission.read_text())
    assert len(data["trace_texts"]) == len(data["rows"]) == 2
    for text, digest in zip(data["trace_texts"], data["traces"], strict=True):
        assert hashlib.sha256(text.encode()).hexdigest() == digest and len(text.splitlines()) > len(CALLS)
    edited = {**data, "trace_texts": [data["trace_texts"][0].replace("teapot", "kettle"), data["trace_texts"][1]]}
    path = submission.with_name("edited-trace.json")
    path.write_text(json.dumps(edited))
    assert main(["submit", "validate", str(path)]) == 2
    assert "the trace text of row 1 does not match its digest" in capsys.readouterr().err


def test_an_honest_submission_verifies_and_the_leaderboard_says_so(
    submission: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    done = verify(submission)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"{submission}: replayed 2 of 2 attempts in ")
    assert "every verdict as recorded" in done.stdout
    record = json.loads(submission.with_name("submission.replay.json").read_text())
    assert [r["status"] for r in record["rows"]] == ["matches", "matches"]
    out = tmp_path / "board"
    assert main(["leaderboard", str(submission), "--out", str(out)]) == 0
    (entry,) = json.loads((out / "leaderboard.json").read_text())["entries"]
    assert entry["verified"] is True and (entry["replayed"], entry["replayable"]) == (2, 2)
    assert "| fixed | robocog | yes (2 of 2 replayed) |" in (out / "leaderboard.md").read_text()


def test_an_edited_verdict_fails_verify_naming_the_attempt(
    submission: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = json.loads(submission.read_text())
    data["rows"][1]["true_success"] = True  # the second trial "succeeded"; the digest recomputed to match
    data["rows"][1]["agreement"] = True
    data["rows_sha256"] = sha256_of(data["rows"])
    forged = tmp_path / "forged.json"
    forged.write_text(json.dumps(data))
    assert main(["submit", "validate", str(forged)]) == 0  # every digest holds: only replay finds it
    capsys.readouterr()
    done = verify(forged)
    assert done.returncode == 1
    assert done.stderr == (
        f"robocog: {forged}: row 2 (fixed, trial 1, iteration 0, T1) differs: true_success recorded True, "
        "replayed False; achieved recorded True, replayed False\n"
    )
    assert "replayed 2 of 2 attempts" in done.stdout and "1 verdicts differ" in done.stdout
    out = tmp_path / "board"
    assert main(["leaderboard", str(forged), "--out", str(out)]) == 0
    (entry,) = json.loads((out / "leaderboard.json").read_text())["entries"]
    assert entry["verified"] is False and entry["problems"] == ["replay differs (1 rows)"]
    forged.write_text(forged.read_text() + " ")  # changed after it was verified: its record no longer counts
    assert main(["leaderboard", str(forged), "--out", str(out)]) == 0
    (entry,) = json.loads((out / "leaderboard.json").read_text())["entries"]
    assert entry["problems"] == ["not replayed (2 rows)"] and entry["replayed"] == 0


def test_verify_refuses_a_submission_without_traces_in_one_line(submission: Path, tmp_path: Path) -> None:
    data = json.loads(submission.read_text())
    del data["trace_texts"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    done = verify(old)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "carries no traces to replay" in done.stderr
