"""Fresh splits (issue 47): a study names a split generated on demand from a seed (`split: test@SEED`),
in real `robocog` processes. A tiny suite of the verifier's own (`--suite-dir`: three of robocog-v2.1's
families, one with an earlier task, one instance each, the paper's house) keeps each split at three
instances: the planner runs it, the rows carry the seed, `submit validate` and `submit verify`
regenerate it from the seed and replay it (the earlier task in its instance's world), and the
leaderboard keeps two seeds apart. A hostile seed is refused in one line, exit 2."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.shared.suite import SUITES_DIR

MANIFEST = """name: tiny
families: [put_away, swap, memory]
scenes: [household]
tagged: true
family_dir: families
describes_objects: true
fair_goals: true
splits:
  dev: {seed: 1, per_family: 1}
  test: {seed: 2, per_family: 1}
"""


def robocog(*args: str | Path, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "robocog.agent.cli", *map(str, args)]
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """A folder with the tiny suite and a study of the planner on it, and an environment whose fresh
    splits are cached in the folder."""
    folder = tmp_path_factory.mktemp("fresh")
    suite = folder / "tiny"
    suite.mkdir()
    shutil.copytree(SUITES_DIR / "robocog-v2.1" / "families", suite / "families")
    (suite / "suite.yaml").write_text(MANIFEST)
    study = "name: fresh\nmodels: [{model: scripted/planner, label: planner}]\n"
    study += f"suite: {suite}\nsplit: test\ntrials: 1\nmemory_iterations: 1\nworkers: 1\n"
    (folder / "study.yaml").write_text(study)
    env = {**os.environ, "ROBOCOG_SPLITS_CACHE": str(folder / "cache")}
    return folder, env


@pytest.fixture(scope="module")
def runs(world: tuple[Path, dict[str, str]]) -> dict[int, Path]:
    """The study run on two fresh splits (seeds 12345 and 777), each packed as a submission."""
    folder, env = world
    out = {}
    for seed in (12345, 777):
        results = folder / f"r{seed}" / "results.jsonl"
        split = f"test@{seed}"
        done = robocog("eval", "study.yaml", "--split", split, "--out", results, "--quiet", cwd=folder, env=env)
        assert done.returncode == 0, done.stderr
        assert f"generating tiny test@{seed} from its seed" in done.stderr
        assert f"generated tiny test@{seed}: 3 instances" in done.stderr
        submission = folder / f"s{seed}.json"
        done = robocog("submit", "prepare", results, "--out", submission, "--suite-dir", "tiny", cwd=folder, env=env)
        assert done.returncode == 0, done.stderr
        out[seed] = submission
    return out


def test_a_study_on_a_fresh_split_records_its_seed(world: tuple[Path, dict[str, str]], runs: dict[int, Path]) -> None:
    folder, env = world
    rows = [json.loads(line) for line in (folder / "r12345" / "results.jsonl").read_text().splitlines()]
    assert [(r["instance"], r.get("earlier")) for r in rows] == [
        ("test-put_away-000", None), ("test-swap-000", None), ("test-memory-000", 1), ("test-memory-000", None),
    ]  # fmt: skip
    assert all(r["true_success"] for r in rows)  # the planner solves them, the earlier task too
    own = [r["provenance"] for r in rows if r.get("earlier") is None]  # an earlier task's names no suite
    assert {(p["suite"], p["split"], p["split_seed"]) for p in own} == {("tiny", "test", 12345)}
    # the instances are those `robocog suite generate --seed` writes, byte for byte
    cached = next((folder / "cache").glob("*/tiny/test@12345.jsonl"))
    done = robocog("suite", "generate", "--suite", "tiny", "--split", "test", "--seed", "12345", cwd=folder, env=env)
    assert done.returncode == 0 and done.stdout == cached.read_text()
    other = next((folder / "cache").glob("*/tiny/test@777.jsonl")).read_text()
    assert other != cached.read_text()  # another seed, other instances under the same ids
    assert json.loads(runs[12345].read_text())["split"] == "test@12345"


def test_validate_and_verify_regenerate_the_split_from_its_seed(
    world: tuple[Path, dict[str, str]], runs: dict[int, Path]
) -> None:
    folder, env = world
    shutil.rmtree(folder / "cache")  # the verifier's machine has never seen the seed
    done = robocog("submit", "validate", runs[12345], "--suite-dir", "tiny", cwd=folder, env=env)
    assert done.returncode == 0, done.stderr
    assert "valid (4 rows, 1 trials per instance, tiny/test@12345)" in done.stdout
    done = robocog("submit", "verify", runs[12345], "--suite-dir", "tiny", cwd=folder, env=env)
    assert done.returncode == 0, done.stderr
    # the earlier task too, in the world of its instance (of the fresh split, not the shipped one)
    assert "replayed 4 of 4 attempts" in done.stdout and "every verdict as recorded" in done.stdout
    # a submission that says another seed than its rows ran on is refused
    data = json.loads(runs[12345].read_text())
    (folder / "claims.json").write_text(json.dumps({**data, "split": "test@777"}))
    done = robocog("submit", "validate", "claims.json", "--suite-dir", "tiny", cwd=folder, env=env)
    assert done.returncode == 2
    assert "declares tiny / test@777, but its rows ran on tiny / test@12345" in done.stderr


def test_the_leaderboard_keeps_two_seeds_apart(world: tuple[Path, dict[str, str]], runs: dict[int, Path]) -> None:
    folder, env = world
    board = folder / "board"
    done = robocog("leaderboard", runs[12345], runs[777], "--suite-dir", "tiny", "--out", board, cwd=folder, env=env)
    assert done.returncode == 0, done.stderr
    entries = json.loads((board / "leaderboard.json").read_text())["entries"]
    assert sorted((e["model"], e["suite"], e["split"], e["seed"], e["attempts"]) for e in entries) == [
        ("planner", "tiny", "test", 777, 3),
        ("planner", "tiny", "test", 12345, 3),
    ]
    markdown = (board / "leaderboard.md").read_text()
    assert "| tiny / test@12345 |" in markdown and "| tiny / test@777 |" in markdown


@pytest.mark.parametrize("split", ["test@abc", "test@-1", "test@2147483648", "test@99999999999999999999", "x@1@2"])
def test_a_hostile_seed_is_refused_in_one_line(world: tuple[Path, dict[str, str]], split: str) -> None:
    folder, env = world
    done = robocog("eval", "study.yaml", "--split", split, "--out", folder / "never.jsonl", cwd=folder, env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "SPLIT@SEED, SEED a decimal integer from 0 to 2147483647" in done.stderr
    assert "Traceback" not in done.stderr and not (folder / "never.jsonl").exists()


@pytest.mark.parametrize("split", ["test@abc", "test@-5", "test@2147483648", 12345, "nosuch@3"])
def test_a_submission_with_a_hostile_seed_is_refused_in_one_line(
    world: tuple[Path, dict[str, str]], runs: dict[int, Path], split: object
) -> None:
    folder, env = world
    data = json.loads(runs[777].read_text())
    (folder / "hostile.json").write_text(json.dumps({**data, "split": split}))
    done = robocog("submit", "validate", "hostile.json", "--suite-dir", "tiny", cwd=folder, env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "Traceback" not in done.stderr and "not a valid submission" in done.stderr


def test_a_manifest_asking_too_many_instances_is_not_generated(world: tuple[Path, dict[str, str]]) -> None:
    folder, env = world
    huge = folder / "huge"
    shutil.copytree(folder / "tiny", huge)
    manifest = (huge / "suite.yaml").read_text().replace("per_family: 1}", "per_family: 1000000}")
    (huge / "suite.yaml").write_text(manifest.replace("name: tiny", "name: huge"))
    study = (folder / "study.yaml").read_text().replace(str(folder / "tiny"), str(huge))
    (folder / "huge.yaml").write_text(study)
    done = robocog("eval", "huge.yaml", "--split", "test@5", "--out", folder / "h.jsonl", cwd=folder, env=env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "1000000 instances per family; a fresh split generates at most 100" in done.stderr
