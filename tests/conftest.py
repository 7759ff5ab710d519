"""Suite-wide guards: nothing reaches the network, nothing phones home."""

from __future__ import annotations

import ipaddress
import os
import socket
from collections.abc import Iterator

import pytest

os.environ.setdefault("ANONYMIZED_TELEMETRY", "False")
os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")

_real_connect = socket.socket.connect


def _loopback(address: object) -> bool:
    if isinstance(address, tuple) and address:
        host = str(address[0])
        if host == "localhost":
            return True
        try:
            return ipaddress.ip_address(host.split("%")[0]).is_loopback
        except ValueError:
            return False
    return isinstance(address, str | bytes)  # AF_UNIX paths are local


def _guarded_connect(self: socket.socket, address: object) -> None:
    if not _loopback(address):
        raise OSError(f"tests are offline: refused a connection to {address!r}")
    _real_connect(self, address)  # type: ignore[arg-type]


#: The modules that take longest, run first: `make test` spreads whole modules over workers
#: (`pytest -n 2 --dist loadfile`, which hands them out in collection order), so a long module left
#: for the end would keep one worker busy while the other idles. The rest keep their order.
SLOW_FIRST = ("test_scale.py", "test_evaluation.py", "test_agent.py", "test_models.py", "test_model_failures.py")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: i for i, name in enumerate(SLOW_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOW_FIRST)))  # stable: ties keep their order


@pytest.fixture
def anyio_backend() -> str:
    """Async tests (marked `anyio`) run on asyncio, fixtures and test in one task."""
    return "asyncio"


@pytest.fixture(autouse=True)
def offline(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Refuse every non-loopback connection, so a test that needs the network fails loudly."""
    monkeypatch.setattr(socket.socket, "connect", _guarded_connect)
    yield
