"""Episodic memory's Chroma plumbing (`robocog.server.memory.chroma`): the work it skips is skipped,
and what it returns is what the slower way returned."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from robocog.server.memory import chroma
from robocog.server.memory.chroma import index_directories, release_heap, tree_size
from robocog.server.memory.episodic import EpisodicMemory


@pytest.fixture
def memory(tmp_path: Path) -> Iterator[EpisodicMemory]:
    with EpisodicMemory(tmp_path / "mem", namespace="speed") as mem:
        yield mem


def test_drop_counts_and_removes_what_rglob_finds(memory: EpisodicMemory) -> None:
    for i in range(3):
        memory.add(f"task {i}", "success", "s")
    memory.search("task", k=1)
    directories = index_directories(memory.location, memory._collection.id)
    assert directories, "a written collection has its index on disk"
    expected = sum(f.stat().st_size for d in directories for f in Path(d).rglob("*") if f.is_file())
    assert sum(tree_size(d) for d in directories) == expected > 0
    assert memory.drop() == expected
    assert not any(Path(d).exists() for d in directories)


def test_tree_size_counts_nested_files_and_not_linked_directories(tmp_path: Path) -> None:
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "a" / "x.bin").write_bytes(b"12345")
    (tmp_path / "a" / "b" / "y.bin").write_bytes(b"123")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "z.bin").write_bytes(b"1234567")
    (tmp_path / "a" / "link").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    root = tmp_path / "a"
    expected = sum(f.stat().st_size for f in root.rglob("*") if f.is_file())
    assert tree_size(str(root)) == expected == 8


def test_release_heap_looks_the_c_library_up_once(monkeypatch: pytest.MonkeyPatch) -> None:
    import ctypes.util

    find = ctypes.util.find_library
    lookups: list[str] = []

    def counted(name: str) -> str | None:
        lookups.append(name)
        return find(name)

    chroma._malloc_trim.cache_clear()
    monkeypatch.setattr(ctypes.util, "find_library", counted)
    try:
        for _ in range(3):
            release_heap()
    finally:
        chroma._malloc_trim.cache_clear()
    assert lookups == ["c"]
