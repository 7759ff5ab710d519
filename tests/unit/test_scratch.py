"""Where a study's own servers keep their memory (robocog.agent.harness.scratch): in RAM where there is
room, removed when the study ends, and swept up after a study that was killed."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.agent.harness import scratch
from robocog.agent.harness.scratch import PREFIX, SCRATCH_ENV, memory_dir, scratch_root, sweep


@pytest.fixture
def ram(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A directory standing for the RAM file system (`ROBOCOG_SCRATCH_DIR`)."""
    root = tmp_path / "ram"
    root.mkdir()
    monkeypatch.setenv(SCRATCH_ENV, str(root))
    return root


def test_the_scratch_root_is_the_named_directory_when_it_has_room(ram: Path) -> None:
    assert scratch_root() == ram


def test_linux_ram_file_system_is_the_default(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv(SCRATCH_ENV, raising=False)
    monkeypatch.setattr(scratch, "DEFAULT_SCRATCH", tmp_path)
    assert scratch_root() == tmp_path


@pytest.mark.parametrize("value", ["", "  "])
def test_an_empty_setting_keeps_the_memory_on_disk(monkeypatch: pytest.MonkeyPatch, value: str) -> None:
    monkeypatch.setenv(SCRATCH_ENV, value)
    assert scratch_root() is None


def test_a_missing_directory_or_a_file_is_no_scratch_root(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv(SCRATCH_ENV, str(tmp_path / "nowhere"))
    assert scratch_root() is None
    (tmp_path / "file").write_text("")
    monkeypatch.setenv(SCRATCH_ENV, str(tmp_path / "file"))
    assert scratch_root() is None


def test_a_scratch_root_without_room_is_not_used(ram: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    free = scratch.shutil.disk_usage(ram).free
    monkeypatch.setattr(scratch, "MIN_FREE_BYTES", free + 1024**3)
    assert scratch_root() is None


def test_a_study_memory_dir_is_its_own_under_the_root_and_gone_when_it_ends(ram: Path, tmp_path: Path) -> None:
    work = tmp_path / "r.work"
    with memory_dir(work, keep_memory=False) as path:
        assert path.parent == ram
        assert path.name.startswith(f"{PREFIX}{os.getpid()}-")
        (path / "worker-0").mkdir()
        (path / "worker-0" / "chroma.sqlite3").write_bytes(b"x")
    assert not path.exists()
    assert list(ram.iterdir()) == []


def test_a_study_memory_dir_is_removed_when_the_study_fails(ram: Path, tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), memory_dir(tmp_path / "r.work", keep_memory=False) as path:
        (path / "worker-0").mkdir()
        raise RuntimeError("the study broke")
    assert list(ram.iterdir()) == []


def test_kept_memory_and_no_scratch_root_mean_the_work_directory(
    ram: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    work = tmp_path / "r.work"
    with memory_dir(work, keep_memory=True) as path:  # every namespace stays until the end: on disk
        assert path == work
    monkeypatch.setenv(SCRATCH_ENV, "")
    with memory_dir(work, keep_memory=False) as path:
        assert path == work
    assert list(ram.iterdir()) == []


def _dead_pid() -> int:
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    return int(done.stdout)


def test_sweep_removes_only_the_memory_of_studies_whose_process_has_gone(ram: Path) -> None:
    dead = ram / f"{PREFIX}{_dead_pid()}-abc"
    (dead / "fleet-0").mkdir(parents=True)
    alive = ram / f"{PREFIX}{os.getpid()}-def"
    alive.mkdir()
    others = [ram / f"{PREFIX}notapid", ram / "someone-else", ram / f"{PREFIX}1-file"]
    others[0].mkdir()
    others[1].mkdir()
    others[2].write_text("a file, not a study's directory")
    assert sweep(ram) == [dead]
    assert sorted(ram.iterdir()) == sorted([alive, *others])


def test_a_new_study_sweeps_up_a_killed_one(ram: Path, tmp_path: Path) -> None:
    killed = ram / f"{PREFIX}{_dead_pid()}-xyz"
    killed.mkdir()
    with memory_dir(tmp_path / "r.work", keep_memory=False) as path:
        assert not killed.exists()
        assert list(ram.iterdir()) == [path]
