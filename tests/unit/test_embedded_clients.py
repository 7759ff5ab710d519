"""The embedded Chroma clients kept running between namespaces (`robocog.server.memory.chroma.EMBEDDED`):
a study's units share one client per data directory, which is stopped once it has served its turn,
and what they write and read is what a client of their own gave them."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from robocog.server.memory import chroma, episodic
from robocog.server.memory.chroma import EmbeddedClients
from robocog.server.memory.episodic import EpisodicMemory
from tests.helpers import ROOT


@pytest.fixture
def clients(monkeypatch: pytest.MonkeyPatch) -> Iterator[EmbeddedClients]:
    """A registry of this test's own (keeping 3 namespaces per client), stopped at the end."""
    mine = EmbeddedClients(keep=3)
    monkeypatch.setattr(episodic, "EMBEDDED", mine)
    yield mine
    mine.stop_idle()


def unit(data: Path, namespace: str) -> list[str]:
    """A study unit's memory: open the namespace, search it, write a record, read it back, drop it."""
    with EpisodicMemory(data, namespace=namespace) as memory:
        assert memory.count() == 0
        assert memory.search("put the mug away") == []
        record = memory.add("put the mug away", "success", f"done in {namespace}")
        memory.set_verified(record.id, "failure")
        found = [(h.record.summary, h.record.verified_status) for h in memory.search("put the mug away")]
        memory.drop()
    return [f"{summary}/{verified}" for summary, verified in found]


def test_units_share_a_client_until_it_has_served_its_turn(tmp_path: Path, clients: EmbeddedClients) -> None:
    for i in range(3):
        assert unit(tmp_path, f"unit-{i}") == [f"done in unit-{i}/failure"]
    assert clients.started == 1
    assert clients.running() == 0, "a client that served its turn is stopped when its last namespace closes"
    for i in range(3, 7):
        assert unit(tmp_path, f"unit-{i}") == [f"done in unit-{i}/failure"]
    assert clients.started == 3 and clients.running() == 1, "units 3-5 on a second client, unit 6 on a third"


def test_a_client_serves_on_while_a_namespace_is_open(tmp_path: Path, clients: EmbeddedClients) -> None:
    """The server's own namespace stays open while units come and go: the client is not stopped
    under it, and what it holds stays readable."""
    with EpisodicMemory(tmp_path, namespace="own") as own:
        own.add("tidy the hallway", "success", "kept")
        for i in range(5):
            unit(tmp_path, f"unit-{i}")
        assert clients.started == 1
        assert [h.record.summary for h in own.search("tidy the hallway")] == ["kept"]
    assert clients.running() == 0


def test_of_idle_clients_only_the_last_released_keeps_running(tmp_path: Path, clients: EmbeddedClients) -> None:
    unit(tmp_path / "a", "one")
    unit(tmp_path / "b", "one")
    assert clients.running() == 1
    unit(tmp_path / "b", "two")
    assert clients.started == 2, "b's client was kept running between its namespaces"
    clients.stop_idle()
    assert clients.running() == 0


def test_records_outlive_the_client_that_wrote_them(tmp_path: Path, clients: EmbeddedClients) -> None:
    with EpisodicMemory(tmp_path, namespace="kept") as memory:
        memory.add("water the plants", "success", "watered")
    for i in range(4):  # past its turn: the client that wrote the record has been stopped since
        unit(tmp_path, f"unit-{i}")
    assert clients.started == 2
    with EpisodicMemory(tmp_path, namespace="kept") as memory:
        assert [h.record.summary for h in memory.search("water the plants")] == ["watered"]


def test_a_store_deleted_between_namespaces_is_made_anew(tmp_path: Path, clients: EmbeddedClients) -> None:
    """The data directory deleted while its client idles (a user clearing it, a test's clean-up): the
    next namespace gets a client on the new store, not one writing into the deleted files."""
    data = tmp_path / "memory"
    unit(data, "first")
    shutil.rmtree(data)
    with EpisodicMemory(data, namespace="second") as memory:
        memory.add("feed the cat", "success", "fed")
    assert clients.started == 2
    with EpisodicMemory(data, namespace="second") as memory:
        assert memory.count() == 1


def test_closing_twice_gives_the_client_back_once(tmp_path: Path, clients: EmbeddedClients) -> None:
    memory = EpisodicMemory(tmp_path, namespace="twice")
    other = EpisodicMemory(tmp_path, namespace="other")
    memory.close()
    memory.close()
    assert clients.running() == 1, "the other namespace still holds the client"
    other.add("sweep the floor", "success", "swept")
    assert other.count() == 1
    other.close()


def test_a_namespace_that_fails_to_open_gives_its_client_back(
    tmp_path: Path, clients: EmbeddedClients, monkeypatch: pytest.MonkeyPatch
) -> None:
    from chromadb.api.client import Client

    def refuse(*_: object, **__: object) -> None:
        raise RuntimeError("no collection today")

    monkeypatch.setattr(Client, "get_or_create_collection", refuse)
    with pytest.raises(RuntimeError, match="no collection today"):
        EpisodicMemory(tmp_path, namespace="refused")
    monkeypatch.undo()
    monkeypatch.setattr(episodic, "EMBEDDED", clients)
    assert unit(tmp_path, "after") == ["done in after/failure"]
    assert clients.running() == 1 and clients._kept[str(tmp_path)].users == 0


def test_a_sessions_units_keep_its_memory_bounded(tmp_path: Path) -> None:
    """A single robot's server (stdio: a process per worker) runs 120 units, each in a namespace of its
    own that it drops: the process's memory stays flat though its client is kept between them.
    Measured in a process of its own, with glibc's malloc kept to the server's arenas (as
    `robocog-server` does at start: with an arena per thread, what Chroma frees stays scattered, and a
    process grew by tens of MB either way), so that what other test modules left here does not count."""
    code = (
        "import sys; from pathlib import Path; from tests.unit.test_embedded_clients import units; "
        "units(Path(sys.argv[1]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr[-3000:]


def units(tmp_path: Path, warm_up: int = 24, count: int = 120) -> None:
    from robocog.shared.process import limit_malloc_arenas

    limit_malloc_arenas()  # first, as robocog-server does
    from robocog.server.config import SessionConfig
    from robocog.server.robots.session import RobotSession
    from tests.helpers import rss_mb

    session = RobotSession(SessionConfig(data_dir=tmp_path / "memory"))
    try:
        for i in range(count):
            if i == warm_up:
                before, started = rss_mb(os.getpid()), chroma.EMBEDDED.started
            session.use_namespace(f"unit-{i}")
            session.memory.search("put the mug away")
            session.memory.add("put the mug away", "success", "done")
            session.drop_namespace()
        grown = rss_mb(os.getpid()) - before
        # a client kept for ever grows 2.6 MB a namespace (about 250 MB here); one stopped every few, by noise
        assert grown < 30, f"RSS grew {grown:.0f} MB over {count - warm_up} units"
        turns = (count - warm_up) / chroma.KEEP_NAMESPACES
        assert turns - 1 <= chroma.EMBEDDED.started - started <= turns + 1
    finally:
        session.close()
