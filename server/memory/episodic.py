"""Episodic memory: past episodes in a ChromaDB collection, searched by task similarity.

Embedded by default (a ``PersistentClient`` in a data directory); with ``url`` a Chroma server that
many robots can share. Each namespace is its own collection. Vectors are computed here with an
offline embedding function and handed to Chroma, so Chroma never loads its own (downloading) one.

Texts are bounded both ways (`robocog.shared.limits`): a description or summary longer than its
limit is stored cut, with a marker, and one read back (written before the limits, or by another
client of a shared server) is cut the same way. A record written for an episode id has an id derived
from it, and writing it again replaces it: one episode, one record, however often its end is retried.

Cost (a study unit: open, count, search, write, verdict, count, drop, close; about 20 ms of CPU): all
but 2 ms is inside Chroma's calls and their threads, one call per step and none redundant
(`chroma` keeps the Python around them lean). Embedded, the namespaces of a data directory share one
client, kept running between them and started afresh every few namespaces (`chroma.EMBEDDED`):
Chroma keeps what each collection held (2.7 MB) until its client stops, and a client started for
each namespace cost a unit 7 ms more.
"""

from __future__ import annotations

import errno
import re
import sqlite3
import threading
import uuid
from collections.abc import Iterable, Mapping, Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path
from types import TracebackType
from typing import Any, NotRequired, Self, TypedDict, cast

import chromadb
import numpy as np
from chromadb.api import ClientAPI
from chromadb.api.models.Collection import Collection
from chromadb.api.types import Documents, EmbeddingFunction
from chromadb.errors import ChromaError

from robocog.server import compat
from robocog.server.memory.chroma import EMBEDDED, client_settings, index_directories, tree_size
from robocog.server.memory.embedding import MiniLMEmbeddingFunction
from robocog.shared.limits import DESCRIPTION_CHARS, EPISODE_ID_CHARS, NAME_CHARS, SUMMARY_CHARS, truncate
from robocog.shared.memory import MemoryHit, MemoryRecord
from robocog.shared.memory_names import collection_name, default_data_dir, parse_chroma_url
from robocog.shared.protocol import MEMORY_FAILED
from robocog.shared.results import Status

#: Distances closer than this count as a tie (broken newest first).
TIE_EPSILON = 1e-6
_WRITE_BATCH = 1024
_STATUSES: tuple[Status, ...] = ("success", "failure")
#: Namespace of the record ids derived from episode ids.
_EPISODE_IDS = uuid.UUID("4f0c3c56-2f55-4d0e-9a53-6f1f4b1f7a11")


#: The errno values of an OSError that are the memory's storage failing (not a caller's mistake).
_STORAGE_ERRNOS = frozenset({errno.ENOSPC, errno.EROFS, errno.EDQUOT, errno.EIO, errno.ENOENT, errno.EACCES})
#: SQLite's words after Chroma's prefixes: "... (code: 13) database or disk is full".
_SQLITE_REASON = re.compile(r"\(code: \d+\)\s*(.+)$")


def storage_problem(exc: BaseException) -> str | None:
    """One line saying why the memory's storage failed (`MEMORY_FAILED`: the reason), when `exc` is such a
    failure: Chroma's error (a full disk, a read-only or removed database, an unreachable Chroma server),
    SQLite's, or an OSError of the file system (full, read-only); else None."""
    if isinstance(exc, OSError) and exc.errno in _STORAGE_ERRNOS:
        reason = exc.strerror or str(exc)
    elif isinstance(exc, ChromaError | sqlite3.Error):
        text = " ".join(str(exc).split()) or type(exc).__name__
        match = _SQLITE_REASON.search(text)
        reason = match.group(1) if match else text
    else:
        return None
    return f"{MEMORY_FAILED}: {reason}"


def record_id(episode: str | None) -> str:
    """The id of the record an episode writes: derived from the episode id (so writing it again
    replaces it), or a new random one for a record of no episode."""
    return uuid.uuid4().hex if episode is None else uuid.uuid5(_EPISODE_IDS, episode).hex


class EpisodeInput(TypedDict):
    """One record to write with :meth:`EpisodicMemory.add_many` (the arguments of ``add``)."""

    task_description: str
    believed_status: Status
    summary: str
    model: NotRequired[str | None]
    tool_calls: NotRequired[int | None]
    duration_s: NotRequired[float | None]
    verified_status: NotRequired[Status | None]
    episode: NotRequired[str | None]


_clock_lock = threading.Lock()
_last_created: datetime | None = None


def _now() -> datetime:
    """Current UTC time, strictly increasing within the process (so order is always defined)."""
    global _last_created
    with _clock_lock:
        now = datetime.now(UTC)
        if _last_created is not None and now <= _last_created:
            now = _last_created + timedelta(microseconds=1)
        _last_created = now
        return now


def _check_status(name: str, value: object, *, optional: bool = False) -> None:
    if value is None and optional:
        return
    if value not in _STATUSES:
        raise ValueError(f"{name} must be 'success' or 'failure', got {value!r}")


class EpisodicMemory:
    """Past episodes of one namespace, searchable by how similar their task is to a new one."""

    def __init__(
        self,
        data_dir: Path | None = None,
        *,
        url: str | None = None,
        namespace: str = "default",
        embedding_function: EmbeddingFunction[Documents] | None = None,
    ) -> None:
        """Open (creating if needed) the namespace's collection.

        Args:
            data_dir: directory of the embedded database (default: the user data dir).
            url: ``http(s)://host:port`` of a Chroma server instead of the embedded database.
            namespace: which memory to use; each namespace is a separate collection.
            embedding_function: a Chroma embedding function (default: offline MiniLM).
        """
        if data_dir is not None and url is not None:
            raise ValueError("give either data_dir (embedded memory) or url (a Chroma server), not both")
        name = collection_name(namespace)
        self.namespace = namespace
        self._ef: EmbeddingFunction[Documents] = (
            MiniLMEmbeddingFunction() if embedding_function is None else embedding_function
        )
        self._client: ClientAPI
        self._url = url
        if url is not None:
            host, port, ssl = parse_chroma_url(url)
            try:
                self._client = chromadb.HttpClient(host=host, port=port, ssl=ssl, settings=client_settings())
            except Exception as e:
                raise ConnectionError(f"cannot reach the Chroma server at {url}: {e}") from e
            self.location = url
        else:
            path = Path(data_dir) if data_dir is not None else default_data_dir()
            path.mkdir(parents=True, exist_ok=True)
            self.location = str(path)
            self._client = EMBEDDED.acquire(self.location)  # kept running between namespaces
        self._closed = False
        try:
            self._collection: Collection = self._client.get_or_create_collection(
                name,
                configuration={"hnsw": {"space": "cosine"}},
                embedding_function=cast(Any, self._ef),  # Chroma's annotation is narrower than its protocol
            )
        except BaseException:
            self.close()
            raise

    # -- writing ------------------------------------------------------------------------------

    def add(
        self,
        task_description: str,
        believed_status: Status,
        summary: str,
        *,
        model: str | None = None,
        tool_calls: int | None = None,
        duration_s: float | None = None,
        verified_status: Status | None = None,
        episode: str | None = None,
    ) -> MemoryRecord:
        """Store one episode and return the record written (replacing the record of the same `episode`, if any)."""
        entry: EpisodeInput = {
            "task_description": task_description,
            "believed_status": believed_status,
            "summary": summary,
            "model": model,
            "tool_calls": tool_calls,
            "duration_s": duration_s,
            "verified_status": verified_status,
            "episode": episode,
        }
        return self.add_many([entry])[0]

    def add_many(self, entries: Iterable[EpisodeInput]) -> list[MemoryRecord]:
        """Store several episodes at once (embedded in batches); later entries count as newer. An entry
        with an `episode` replaces that episode's record (an earlier one in the same call, too); texts
        over their limits are stored cut, with a marker."""
        records: list[MemoryRecord] = []
        for entry in entries:
            text = entry["task_description"]
            if not isinstance(text, str) or not text.strip():
                raise ValueError("task_description must be a non-empty description of the task")
            _check_status("believed_status", entry["believed_status"])
            _check_status("verified_status", entry.get("verified_status"), optional=True)
            episode = entry.get("episode")
            if episode is not None and not 0 < len(episode) <= EPISODE_ID_CHARS:
                raise ValueError(f"an episode id has 1 to {EPISODE_ID_CHARS} characters, got {len(episode)}")
            records.append(
                MemoryRecord(
                    **_bounded(cast(Mapping[str, Any], entry)),
                    id=record_id(episode),
                    created_at=_now().isoformat(timespec="microseconds"),
                )
            )
        # Chroma refuses one id twice in a write: the last entry of an episode is the one kept.
        latest = {r.id: r for r in records}
        unique = [r for r in records if latest[r.id] is r]
        for start in range(0, len(unique), _WRITE_BATCH):
            batch = unique[start : start + _WRITE_BATCH]
            documents = [r.task_description for r in batch]
            self._collection.upsert(
                ids=[r.id for r in batch],
                documents=documents,
                embeddings=self._embed(documents),
                metadatas=[_to_metadata(r) for r in batch],
            )
        return records

    def set_verified(self, record_id: str, status: Status | None) -> MemoryRecord:
        """Record the ground-truth outcome of an episode (None clears it); return the updated record."""
        _check_status("status", status, optional=True)
        record = self.get(record_id)
        if record is None:
            raise KeyError(f"no memory record with id {record_id!r} in namespace {self.namespace!r}")
        # Chroma merges metadata on update; a None value deletes the key.
        self._collection.update(ids=[record.id], metadatas=[{"verified_status": status}])
        return record.model_copy(update={"verified_status": status})

    def clear(self) -> None:
        """Delete every record of this namespace (other namespaces are untouched)."""
        ids = self._collection.get(include=[])["ids"]
        step = max(1, min(self._client.get_max_batch_size(), 5000))
        for start in range(0, len(ids), step):
            self._collection.delete(ids=ids[start : start + step])

    def drop(self) -> int:
        """Delete the namespace itself: its collection and, embedded, its index files on disk (the
        memory cannot be used after; opening the namespace again makes it anew, empty). Returns the
        bytes of files removed (0 on a Chroma server). Chroma's own `delete_collection` leaves the
        index directories behind, so they are found in its catalogue first and removed after."""
        import shutil

        directories = [] if self._url is not None else index_directories(self.location, self._collection.id)
        size = sum(tree_size(directory) for directory in directories)
        self._client.delete_collection(self._collection.name)
        for directory in directories:
            shutil.rmtree(directory, ignore_errors=True)
        return size

    # -- reading ------------------------------------------------------------------------------

    def search(self, query: str, k: int = 3) -> list[MemoryHit]:
        """The ``k`` records whose task is closest to ``query``, closest first.

        Equal distances (within ``TIE_EPSILON``) are ordered newest first.
        """
        if not isinstance(query, str) or not query.strip():
            raise ValueError("query must be a non-empty task description, e.g. 'put the apple in the fridge'")
        if k < 1:
            raise ValueError(f"k must be at least 1, got {k}")
        vector = self._embed_query(query)
        # Fetch a little more than k; widen while the k-th hit ties with the last one fetched, so
        # the newest of tied records can be chosen. Fewer hits than asked means all were fetched.
        n = k + 2
        while True:
            res = self._collection.query(
                query_embeddings=vector, n_results=n, include=["documents", "metadatas", "distances"]
            )
            hits = [
                MemoryHit(record=_to_record(i, d, m), distance=max(0.0, float(dist)))
                for i, d, m, dist in zip(
                    res["ids"][0],
                    (res["documents"] or [[]])[0],
                    (res["metadatas"] or [[]])[0],
                    (res["distances"] or [[]])[0],
                    strict=True,
                )
            ]
            if len(hits) < n or hits[-1].distance - hits[k - 1].distance > TIE_EPSILON:
                break
            n *= 4
        return _order(hits)[:k]

    def get(self, record_id: str) -> MemoryRecord | None:
        """The record with this id, or None."""
        res = self._collection.get(ids=[record_id], include=["documents", "metadatas"])
        if not res["ids"]:
            return None
        return _to_record(res["ids"][0], (res["documents"] or [""])[0], (res["metadatas"] or [{}])[0])

    def count(self) -> int:
        """Number of records in this namespace."""
        return self._collection.count()

    def records(self) -> list[MemoryRecord]:
        """All records of this namespace, newest first."""
        res = self._collection.get(include=["documents", "metadatas"])
        recs = [
            _to_record(i, d, m)
            for i, d, m in zip(res["ids"], res["documents"] or [], res["metadatas"] or [], strict=True)
        ]
        recs.sort(key=lambda r: datetime.fromisoformat(r.created_at), reverse=True)
        return recs

    # -- lifecycle ----------------------------------------------------------------------------

    def close(self) -> None:
        """Release the client (closing it again does nothing). Embedded, the client goes back to the
        process's `EMBEDDED` clients, which stop it once it has served its turn; on a Chroma server,
        the connection pools close once no one else uses them."""
        if self._closed:
            return
        self._closed = True
        if self._url is None:
            EMBEDDED.release(self.location)
            return
        compat.close_chroma_pools(self._client)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- helpers ------------------------------------------------------------------------------

    def _embed(self, documents: list[str]) -> list[np.ndarray]:
        return [np.asarray(v, dtype=np.float32) for v in self._ef(documents)]

    def _embed_query(self, query: str) -> list[np.ndarray]:
        return [np.asarray(v, dtype=np.float32) for v in self._ef.embed_query([query])]


def _to_metadata(record: MemoryRecord) -> dict[str, str | int | float | None]:
    """Chroma metadata of a record: everything but id and document. A None value is written as None,
    which Chroma's upsert takes as "delete this key": a replaced record keeps nothing of the old one
    (such as its verified status)."""
    data = record.model_dump(exclude={"id", "task_description"})
    return cast(dict[str, str | int | float | None], data)


#: The texts of a record and their limits, on the way in and on the way out.
_TEXT_LIMITS = {"task_description": DESCRIPTION_CHARS, "summary": SUMMARY_CHARS, "model": NAME_CHARS}


def _bounded(fields: Mapping[str, Any]) -> dict[str, Any]:
    """`fields` with each text of `_TEXT_LIMITS` cut to its limit (with a marker)."""
    return {
        k: truncate(v, _TEXT_LIMITS[k]) if k in _TEXT_LIMITS and isinstance(v, str) else v for k, v in fields.items()
    }


def _to_record(record_id: str, document: str | None, metadata: Mapping[str, Any] | None) -> MemoryRecord:
    # Keys a newer robocog may have added are ignored, so a shared server can serve mixed versions;
    # texts over their limits (a record written before them) are cut.
    known = {k: v for k, v in (metadata or {}).items() if k in MemoryRecord.model_fields}
    return MemoryRecord.model_validate(_bounded({**known, "id": record_id, "task_description": document or ""}))


def _order(hits: Sequence[MemoryHit]) -> list[MemoryHit]:
    """Sort by distance; within a run of ties (consecutive distances within epsilon), newest first."""
    by_distance = sorted(hits, key=lambda h: h.distance)
    out: list[MemoryHit] = []
    group: list[MemoryHit] = []
    for hit in by_distance:
        if group and hit.distance - group[0].distance > TIE_EPSILON:
            out.extend(sorted(group, key=lambda h: datetime.fromisoformat(h.record.created_at), reverse=True))
            group = []
        group.append(hit)
    out.extend(sorted(group, key=lambda h: datetime.fromisoformat(h.record.created_at), reverse=True))
    return out
