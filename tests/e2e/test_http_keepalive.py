"""One TCP connection for an attempt over HTTP: robocog's client reads each answer to its end, so
the connection is kept for the next call (the MCP SDK alone opened one per call)."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from mcp import Client

from robocog.agent.client.aiohttp_transport import AiohttpTransport
from robocog.agent.client.connection import _http_transport
from tests.helpers import free_port, server_command

pytestmark = pytest.mark.anyio

CALLS = 20


@pytest.fixture(scope="module")
def url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("keepalive")
    port = free_port()
    log = tmp / "server.log"
    with log.open("w") as out:
        command = [*server_command(), "--transport", "http", "--port", str(port), "--data-dir", str(tmp / "memory")]
        env = {**os.environ, "ANONYMIZED_TELEMETRY": "False"}
        proc = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=env)
        try:
            _wait_for_port(proc, port, log)
            yield f"http://127.0.0.1:{port}/mcp"
        finally:
            proc.terminate()
            proc.wait(timeout=10)


def _wait_for_port(proc: subprocess.Popen[bytes], port: int, log: Path) -> None:
    deadline = time.monotonic() + 90  # a loaded machine starts PyBullet and Chroma slowly
    while time.monotonic() < deadline:
        assert proc.poll() is None, log.read_text()
        try:
            httpx.get(f"http://127.0.0.1:{port}/", timeout=0.5)
            return
        except httpx.TransportError:
            time.sleep(0.1)
    raise AssertionError(f"the server did not start: {log.read_text()}")


async def test_calls_over_http_share_one_connection(url: str, monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[AiohttpTransport] = []
    real = AiohttpTransport.__init__

    def recorded(self: AiohttpTransport, **kwargs: float) -> None:
        real(self, **kwargs)
        made.append(self)

    monkeypatch.setattr(AiohttpTransport, "__init__", recorded)
    async with Client(_http_transport(url, None), mode="legacy") as client:
        await client.call_tool("look_around", {})  # the session, its GET stream and the world are set up
        (transport,) = made  # plain HTTP goes through aiohttp
        before = transport.connections_opened
        for _ in range(CALLS):
            assert not (await client.call_tool("look_around", {})).is_error
        opened = transport.connections_opened - before
    # One per call without the draining; at most one more than the pooled one with it (a call may
    # start while the previous answer's last bytes are still being read).
    assert opened <= 1, opened
    assert transport.connections_opened >= 2  # the count counts: the POSTs' and the GET stream's
