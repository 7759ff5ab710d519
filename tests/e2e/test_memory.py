"""Episodic memory (embedded ChromaDB) and the scratchpad."""

import os
import subprocess
import sys
import time
import urllib.request
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from robocog.server.memory.episodic import EpisodicMemory, parse_chroma_url, record_id
from robocog.server.memory.scratchpad import Scratchpad
from robocog.shared.limits import EPISODE_ID_CHARS
from tests.helpers import free_port


@pytest.fixture
def memory(tmp_path: Path) -> Iterator[EpisodicMemory]:
    with EpisodicMemory(tmp_path / "mem") as mem:
        yield mem


TASKS = [
    "put the apple in the fridge",
    "wipe the kitchen table with the sponge",
    "stack the red block on the blue block",
    "put away all the items into the shelf",
    "turn on the lamp in the bedroom",
]


# -- episodic memory ---------------------------------------------------------------------------


def test_empty_memory_search_returns_nothing(memory: EpisodicMemory) -> None:
    assert memory.search("open the fridge") == []
    assert memory.count() == 0


def test_search_ranks_matching_task_first(memory: EpisodicMemory) -> None:
    for task in TASKS:
        memory.add(task, "success", f"did: {task}")
    hits = memory.search("place the objects on the shelf", k=3)
    assert len(hits) == 3
    assert hits[0].record.task_description == "put away all the items into the shelf"
    assert [h.distance for h in hits] == sorted(h.distance for h in hits)


def test_search_clamps_k_to_count(memory: EpisodicMemory) -> None:
    memory.add(TASKS[0], "success", "ok")
    assert len(memory.search("fridge", k=10)) == 1


def test_search_ties_are_newest_first(memory: EpisodicMemory) -> None:
    memory.add("open the drawer", "failure", "first")
    for i in range(6):
        memory.add("put the apple in the fridge", "success", f"attempt {i}")
    hits = memory.search("put the apple in the fridge", k=3)
    assert [h.record.summary for h in hits] == ["attempt 5", "attempt 4", "attempt 3"]


def test_empty_query_is_rejected(memory: EpisodicMemory) -> None:
    with pytest.raises(ValueError, match="non-empty task description"):
        memory.search("   ")


def test_add_stores_all_fields_and_omits_none(memory: EpisodicMemory) -> None:
    rec = memory.add(
        "put the apple in the fridge", "success", "opened, placed, closed", model="m", tool_calls=7, duration_s=1.5
    )
    assert memory.get(rec.id) == rec
    assert rec.verified_status is None and rec.episode is None
    assert memory.get("no-such-id") is None


def test_set_verified_round_trips(memory: EpisodicMemory) -> None:
    rec = memory.add("put the apple in the fridge", "success", "done")
    assert memory.set_verified(rec.id, "failure").verified_status == "failure"
    stored = memory.get(rec.id)
    assert stored is not None and stored.verified_status == "failure"
    assert stored.summary == "done"
    memory.set_verified(rec.id, None)
    cleared = memory.get(rec.id)
    assert cleared is not None and cleared.verified_status is None


def test_set_verified_unknown_id_raises(memory: EpisodicMemory) -> None:
    with pytest.raises(KeyError):
        memory.set_verified("missing", "success")


def test_records_are_newest_first(memory: EpisodicMemory) -> None:
    written = memory.add_many([{"task_description": t, "believed_status": "success", "summary": t} for t in TASKS])
    assert [r.id for r in memory.records()] == [r.id for r in reversed(written)]


def test_persists_across_instances(tmp_path: Path) -> None:
    with EpisodicMemory(tmp_path, namespace="robot-1") as first:
        rec = first.add("put the apple in the fridge", "success", "done")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        reopened = EpisodicMemory(tmp_path, namespace="robot-1")
    with reopened:
        assert reopened.count() == 1
        assert reopened.search("apple into the fridge")[0].record == rec


def test_fresh_namespace_is_empty(tmp_path: Path) -> None:
    with EpisodicMemory(tmp_path, namespace="a") as a:
        a.add("put the apple in the fridge", "success", "done")
    with EpisodicMemory(tmp_path, namespace="b") as b:
        assert b.count() == 0
        assert b.search("put the apple in the fridge") == []


def test_clear_only_clears_its_namespace(tmp_path: Path) -> None:
    with EpisodicMemory(tmp_path, namespace="a") as a, EpisodicMemory(tmp_path, namespace="b") as b:
        a.add("put the apple in the fridge", "success", "done")
        b.add("wipe the table", "failure", "missed a spot")
        a.clear()
        assert a.count() == 0 and a.search("apple") == []
        assert b.count() == 1


def test_bad_status_is_rejected(memory: EpisodicMemory) -> None:
    with pytest.raises(ValueError, match="'success' or 'failure'"):
        memory.add("open the fridge", "maybe", "?")  # type: ignore[arg-type]


@pytest.mark.parametrize("namespace", ["", "has space", "-lead", "trail-", "a..b", "x" * 60, "ümlaut"])
def test_bad_namespace_is_rejected(tmp_path: Path, namespace: str) -> None:
    with pytest.raises(ValueError, match="invalid memory namespace"):
        EpisodicMemory(tmp_path, namespace=namespace)


@pytest.mark.parametrize(
    "url", ["localhost:8000", "ftp://host:1", "http://", "http://host:notaport", "http://h:1/path", "http://u:p@h"]
)
def test_bad_url_is_rejected(url: str) -> None:
    with pytest.raises(ValueError, match="malformed Chroma URL"):
        EpisodicMemory(url=url)


def test_url_parsing() -> None:
    assert parse_chroma_url("http://chroma.local:9000") == ("chroma.local", 9000, False)
    assert parse_chroma_url("https://chroma.example/") == ("chroma.example", 443, True)
    assert parse_chroma_url("http://127.0.0.1") == ("127.0.0.1", 8000, False)


def test_data_dir_and_url_together_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not both"):
        EpisodicMemory(tmp_path, url="http://localhost:8000")


def test_unreachable_server_is_a_connection_error() -> None:
    with pytest.raises(ConnectionError, match="cannot reach the Chroma server"):
        EpisodicMemory(url="http://127.0.0.1:1")


def test_shared_server_by_url(tmp_path: Path) -> None:
    """Two clients of one local Chroma server (as two robots would be) share a namespace."""
    port = free_port()
    command = [sys.executable, "-c", "from chromadb.cli.cli import app; app()", "run", "--path", str(tmp_path)]
    server = subprocess.Popen(
        [*command, "--host", "127.0.0.1", "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "ANONYMIZED_TELEMETRY": "False"},
    )
    try:
        deadline = time.monotonic() + 20
        while True:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{port}/api/v2/heartbeat", timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline or server.poll() is not None:
                    pytest.fail("the local Chroma server did not start")
                time.sleep(0.1)
        url = f"http://127.0.0.1:{port}"
        with EpisodicMemory(url=url, namespace="fleet") as robot1, EpisodicMemory(url=url, namespace="fleet") as robot2:
            rec = robot1.add("put the apple in the fridge", "success", "done")
            assert robot2.search("apple into the fridge", k=1)[0].record == rec
    finally:
        server.terminate()
        server.wait(timeout=10)


# -- scratchpad --------------------------------------------------------------------------------


def test_scratchpad_add_and_view() -> None:
    pad = Scratchpad()
    pad.add("the mug is in the sink")
    result = pad.add("  the fridge is closed \n")
    assert (result.entries, result.dropped) == (2, 0)
    assert pad.view() == "the mug is in the sink\n\nthe fridge is closed"


def test_scratchpad_drops_oldest_over_max_entries() -> None:
    pad = Scratchpad(max_entries=2)
    pad.add("one")
    pad.add("two")
    result = pad.add("three")
    assert result.dropped == 1
    assert pad.entries == ["two", "three"]


def test_scratchpad_drops_oldest_over_max_chars() -> None:
    pad = Scratchpad(max_chars=10, max_entry_chars=10)
    pad.add("aaaa")
    pad.add("bbbb")
    result = pad.add("cccccc")
    assert (result.dropped, result.chars) == (1, 10)
    assert pad.entries == ["bbbb", "cccccc"]


def test_scratchpad_rejects_overlong_entry() -> None:
    pad = Scratchpad(max_entry_chars=5)
    with pytest.raises(ValueError, match="6 characters, over the limit of 5"):
        pad.add("abcdef")
    assert pad.entries == []


def test_scratchpad_rejects_empty_entry() -> None:
    with pytest.raises(ValueError, match="empty"):
        Scratchpad().add(" \n ")


def test_scratchpad_clear() -> None:
    pad = Scratchpad()
    pad.add("note")
    pad.clear()
    assert (pad.entries, pad.view(), pad.chars) == ([], "", 0)


# -- one record per episode ----------------------------------------------------------------------


def test_a_record_written_again_for_its_episode_replaces_it(memory: EpisodicMemory) -> None:
    first = memory.add("put the mug away", "success", "first try", episode="attempt-1", model="m")
    memory.set_verified(first.id, "failure")
    second = memory.add("put the mug away", "failure", "second try", episode="attempt-1")
    assert second.id == first.id == record_id("attempt-1")
    assert memory.count() == 1
    stored = memory.get(first.id)
    assert stored is not None
    assert (stored.summary, stored.believed_status, stored.episode) == ("second try", "failure", "attempt-1")
    assert stored.verified_status is None and stored.model is None  # nothing of the replaced record is kept


def test_records_of_other_episodes_or_of_none_are_kept_apart(memory: EpisodicMemory) -> None:
    memory.add("put the mug away", "success", "a", episode="attempt-1")
    memory.add("put the mug away", "success", "b", episode="attempt-2")
    memory.add("put the mug away", "success", "c")
    memory.add("put the mug away", "success", "c")
    assert memory.count() == 4


def test_add_many_keeps_the_last_entry_of_an_episode(memory: EpisodicMemory) -> None:
    records = memory.add_many(
        [
            {"task_description": "task", "believed_status": "success", "summary": "one", "episode": "e"},
            {"task_description": "task", "believed_status": "success", "summary": "two", "episode": "e"},
            {"task_description": "task", "believed_status": "success", "summary": "other"},
        ]
    )
    assert memory.count() == 2
    stored = memory.get(records[0].id)
    assert stored is not None and stored.summary == "two"


def test_an_overlong_episode_id_is_rejected(memory: EpisodicMemory) -> None:
    with pytest.raises(ValueError, match="episode id"):
        memory.add("task", "success", "s", episode="e" * (EPISODE_ID_CHARS + 1))
