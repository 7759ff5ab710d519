"""ChromaDB plumbing for episodic memory, kept lean: every unit of a study opens a namespace, writes
to it and drops it, and Chroma holds the GIL through most of that, so what is spent around its calls
is spent by the whole process.

Here: the client settings (made once), the embedded clients kept running between namespaces
(`EMBEDDED`), the catalogue lookup of a collection's index directories and their size (for
`EpisodicMemory.drop`), and the C heap trim done after a client stops.
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from uuid import UUID

from chromadb.config import Settings

if TYPE_CHECKING:
    from chromadb.api import ClientAPI


@functools.cache
def _base_settings() -> Settings:
    """Chroma's settings, telemetry off: made once (a `Settings()` reads the environment, 4 ms)."""
    os.environ["ANONYMIZED_TELEMETRY"] = "False"
    return Settings(anonymized_telemetry=False)


def client_settings() -> Settings:
    """A copy of the settings for one client (`chromadb.PersistentClient` writes its path into them)."""
    return _base_settings().model_copy()


#: Namespaces an embedded client opens before it is stopped and started afresh. Chroma keeps what every
#: collection its client opened held (about 2.7 MB each, dropped or not) until the client stops, so a
#: client kept for ever would grow with every unit of a study; one started for each namespace cost a
#: unit more CPU (its start, its first statements, its stop and the heap trim: the `memory.unit.*`
#: figures of `make bench --only memory`).
KEEP_NAMESPACES = 8


@dataclass
class _Kept:
    client: ClientAPI
    #: The database file as the client found it (device, inode): a store deleted or replaced since
    #: (by another process, or a test's clean-up) gets a client of its own.
    identity: tuple[int, int] | None
    users: int = 0
    opened: int = 0


class EmbeddedClients:
    """The embedded Chroma client of each data directory, shared by the namespaces open on it and
    kept running between them: a study's units each open a namespace, write to it and drop it, and a
    client started and stopped for each was most of what the memory cost them.

    Bounded: a client is stopped once `keep` namespaces have been opened on it and none is open any
    more (the next opens a new one), or at `stop_idle` (a fleet closing every namespace to stay
    bounded); of clients no namespace uses, only the one released last is kept running."""

    def __init__(self, keep: int = KEEP_NAMESPACES) -> None:
        self.keep = keep
        self._kept: dict[str, _Kept] = {}
        self._lock = threading.Lock()
        #: How many clients were started, for the tests and the bench.
        self.started = 0

    def acquire(self, path: str) -> ClientAPI:
        """The client of the store at `path` for one namespace more (give it back with `release`)."""
        import chromadb

        with self._lock:
            kept = self._kept.get(path)
            if kept is not None and kept.users == 0 and (kept.opened >= self.keep or kept.identity != _identity(path)):
                self._stop(path)
                kept = None
            if kept is None:
                client = chromadb.PersistentClient(path=path, settings=client_settings())
                kept = self._kept[path] = _Kept(client, _identity(path))
                self.started += 1
            kept.users += 1
            kept.opened += 1
            return kept.client

    def release(self, path: str) -> None:
        """A namespace on `path` is closed: stop its client if it has served its turn, and of the
        clients no one uses keep only this one running."""
        stopped = False
        with self._lock:
            kept = self._kept.get(path)
            if kept is None:
                return
            kept.users -= 1
            if kept.users > 0:
                return
            for other in [p for p, k in self._kept.items() if k.users == 0 and p != path]:
                stopped = self._stop(other) or stopped
            if kept.opened >= self.keep:
                stopped = self._stop(path) or stopped
        if stopped:
            release_heap()

    def stop_idle(self) -> None:
        """Stop every client no namespace uses (and give the C heap back)."""
        with self._lock:
            for path in [path for path, kept in self._kept.items() if kept.users == 0]:
                self._stop(path)
        release_heap()

    def running(self) -> int:
        """How many clients run."""
        return len(self._kept)

    def _stop(self, path: str) -> bool:
        kept = self._kept.pop(path)
        kept.client.close()  # type: ignore[attr-defined]  # Chroma's Client has it, its ClientAPI does not say so
        return True


def _identity(path: str) -> tuple[int, int] | None:
    try:
        found = os.stat(os.path.join(path, "chroma.sqlite3"))
    except OSError:
        return None
    return found.st_dev, found.st_ino


#: The process's embedded clients (every namespace opened on a data directory goes through it).
EMBEDDED = EmbeddedClients()


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
