"""Where a study's own servers keep their memory (robocog.agent.harness.scratch): in RAM where there is
room, removed when the study ends, and swept up after a study that was killed."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from robocog.agent.harness import scratch
from robocog.agent.harness.scratch import LEGACY_AGE_S, LOCK, PREFIX, SCRATCH_ENV, memory_dir, scratch_root, sweep


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


def _study_dir(root: Path, pid: int, tag: str, *, lock: bool = True, age_s: float = 0.0) -> Path:
    """A study's directory as a study makes it (with its lock file, unheld unless a process holds it)."""
    path = root / f"{PREFIX}{pid}-{tag}"
    (path / "fleet-0").mkdir(parents=True)
    if lock:
        (path / LOCK).write_bytes(b"")
    if age_s:
        then = time.time() - age_s
        os.utime(path, (then, then))
    return path


def test_sweep_removes_only_what_no_process_holds(ram: Path) -> None:
    with memory_dir(ram / "unused", keep_memory=False) as held:
        unheld = _study_dir(ram, os.getpid(), "abc")  # its pid is alive, but no one holds its lock
        held_elsewhere = _study_dir(ram, _dead_pid(), "def")  # its pid is gone here...
        fd = os.open(held_elsewhere / LOCK, os.O_RDWR)
        assert scratch._lock(fd)  # ...but a process (another PID namespace's) holds its lock
        others = [ram / f"{PREFIX}notapid", ram / "someone-else", ram / f"{PREFIX}1-file"]
        others[0].mkdir()
        others[1].mkdir()
        others[2].write_text("a file, not a study's directory")
        try:
            assert sweep(ram) == [unheld]
            assert sorted(ram.iterdir()) == sorted([held, held_elsewhere, *others])
        finally:
            os.close(fd)
        assert sweep(ram) == [held_elsewhere]  # let go: now no one holds it
        assert held.is_dir()


def test_a_directory_without_a_lock_is_swept_when_its_process_has_gone_for_a_day(ram: Path) -> None:
    old = _study_dir(ram, _dead_pid(), "old", lock=False, age_s=LEGACY_AGE_S + 60)
    fresh = _study_dir(ram, _dead_pid(), "fresh", lock=False)  # perhaps another PID namespace's: left
    alive = _study_dir(ram, os.getpid(), "alive", lock=False, age_s=LEGACY_AGE_S + 60)
    assert sweep(ram) == [old]
    assert sorted(ram.iterdir()) == sorted([fresh, alive])


def test_a_new_study_sweeps_up_a_killed_one(ram: Path, tmp_path: Path) -> None:
    killed = _study_dir(ram, _dead_pid(), "xyz")
    with memory_dir(tmp_path / "r.work", keep_memory=False) as path:
        assert not killed.exists()
        assert list(ram.iterdir()) == [path]
        assert (path / LOCK).is_file()


#: A study in a child process: it takes its memory directory (sweeping the root), says where, and waits
#: (or, given "brief", ends at once).
_STUDY = """
import sys, time
from pathlib import Path
from robocog.agent.harness.scratch import memory_dir
with memory_dir(Path(sys.argv[1]), keep_memory=False) as path:
    print(path, flush=True)
    if sys.argv[2:] != ["brief"]:
        time.sleep(120)
"""


def _sigint_default() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_study(ram: Path, tmp_path: Path, *wrapper: str, brief: bool = False) -> tuple[subprocess.Popen[str], Path]:
    env = {**os.environ, SCRATCH_ENV: str(ram)}
    args = [*wrapper, sys.executable, "-c", _STUDY, str(tmp_path / "r.work"), *(["brief"] if brief else [])]
    # A study is started as a shell starts one in the foreground: with SIGINT's default action. A
    # child inherits an ignored SIGINT (pytest itself run as a background job of a script has it
    # ignored, and its test then timed out); a study started that way keeps ignoring it, by design.
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True, env=env, preexec_fn=_sigint_default)
    assert proc.stdout is not None
    path = Path(proc.stdout.readline().strip())
    assert path.name.startswith(PREFIX), path
    return proc, path


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_sigint_remove_the_directory(ram: Path, tmp_path: Path, sig: signal.Signals) -> None:
    proc, path = _start_study(ram, tmp_path)
    proc.send_signal(sig)
    proc.wait(timeout=60)
    assert not path.exists()
    assert list(ram.iterdir()) == []


def test_a_killed_study_is_swept_by_the_next(ram: Path, tmp_path: Path) -> None:
    proc, path = _start_study(ram, tmp_path)
    proc.kill()
    proc.wait(timeout=60)
    assert path.is_dir()  # SIGKILL leaves it...
    assert sweep(ram) == [path]  # ...and its lock went with the process


def test_a_live_study_survives_a_study_in_another_pid_namespace(ram: Path, tmp_path: Path) -> None:
    """A study runs here; a second starts and ends in a new PID namespace sharing the file system
    (`unshare --pid --fork --mount-proc`, as a container sharing /dev/shm). There the first study's pid
    names no process, yet its directory is left alone: the second sees its lock held."""
    unshare = shutil.which("unshare")
    if unshare is None or subprocess.run([unshare, "--pid", "--fork", "--mount-proc", "true"]).returncode != 0:
        pytest.skip("unshare --pid --fork --mount-proc is unavailable here (needs util-linux and root)")
    live, path = _start_study(ram, tmp_path)
    try:
        check = f"import os; os.kill({live.pid}, 0)"
        seen = subprocess.run([unshare, "--pid", "--fork", "--mount-proc", sys.executable, "-c", check])
        assert seen.returncode != 0, "the first study's pid must name no process in the new namespace"
        second, second_path = _start_study(ram, tmp_path, unshare, "--pid", "--fork", "--mount-proc", brief=True)
        assert second.wait(timeout=60) == 0
        assert path.is_dir() and (path / LOCK).is_file()
        assert not second_path.exists()
        assert sorted(ram.iterdir()) == [path]
    finally:
        live.terminate()
        live.wait(timeout=60)
    assert list(ram.iterdir()) == []
