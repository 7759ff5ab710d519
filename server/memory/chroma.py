"""ChromaDB plumbing for episodic memory, kept lean: every unit of a study opens a namespace, writes
to it and drops it, and Chroma holds the GIL through most of that, so what is spent around its calls
is spent by the whole process.

Here: the client settings (made once), the catalogue lookup of a collection's index directories and
their size (for `EpisodicMemory.drop`), and the C heap trim done after a client stops.
"""

from __future__ import annotations

import contextlib
import functools
import os
from typing import Any
from uuid import UUID

from chromadb.config import Settings


@functools.cache
def _base_settings() -> Settings:
    """Chroma's settings, telemetry off: made once (a `Settings()` reads the environment, 4 ms)."""
    os.environ["ANONYMIZED_TELEMETRY"] = "False"
    return Settings(anonymized_telemetry=False)


def client_settings() -> Settings:
    """A copy of the settings for one client (`chromadb.PersistentClient` writes its path into them)."""
    return _base_settings().model_copy()


def index_directories(root: str, collection: UUID) -> list[str]:
    """The directories of an embedded database (at `root`) that hold `collection`'s segments: those
    its catalogue lists and that exist (a collection never written to has none)."""
    import sqlite3

    with contextlib.closing(sqlite3.connect(os.path.join(root, "chroma.sqlite3"))) as catalogue:
        rows = catalogue.execute("SELECT id FROM segments WHERE collection = ?", (str(collection),)).fetchall()
    found = (os.path.join(root, str(segment)) for (segment,) in rows)
    return [directory for directory in found if os.path.isdir(directory)]


def tree_size(directory: str) -> int:
    """Bytes of the files under `directory`, links to directories not followed (what `Path.rglob`
    and `is_file` count, without a `Path` made and two `stat` calls for each file)."""
    total = 0
    with os.scandir(directory) as entries:
        for entry in entries:
            if entry.is_dir(follow_symlinks=False):
                total += tree_size(entry.path)
            elif entry.is_file():
                total += entry.stat().st_size
    return total


def release_heap() -> None:
    """Give the C heap's free memory back to the system (glibc's malloc_trim): after Chroma's client
    stops, what its collections held is otherwise kept by the allocator; a no-op elsewhere."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim() -> Any:
    """glibc's malloc_trim, or None: looked up once, as `find_library` runs `ldconfig -p` in a child
    process each time (about 1.9 ms of CPU, the child's included, and as much wall time, at every
    namespace switch or recycling)."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        return ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError):
        return None
