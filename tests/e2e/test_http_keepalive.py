"""One TCP connection for an attempt on a study's own fleet: the lean client's channel
(`json_http`) keeps the connection of its first request for every later one, through a model's turn too."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from typing import Any

import anyio
import pytest

from robocog.agent.client.connection import ServerSpec, connect
from tests.helpers import http_server

pytestmark = pytest.mark.anyio

CALLS = 20


@pytest.fixture(scope="module")
def url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("keepalive")
    with http_server(tmp / "server.log", "--json-response", "--data-dir", str(tmp / "memory"), timeout_s=90) as url:
        yield url


async def test_a_study_s_calls_to_its_fleet_share_one_connection(url: str, monkeypatch: pytest.MonkeyPatch) -> None:
    opened: list[Any] = []
    real = asyncio.BaseEventLoop.create_connection

    async def counted(loop: asyncio.BaseEventLoop, *args: Any, **kwargs: Any) -> Any:
        opened.append(args)
        return await real(loop, *args, **kwargs)

    monkeypatch.setattr(asyncio.BaseEventLoop, "create_connection", counted)
    async with connect(ServerSpec(url=url, lean=True)) as robot:  # the handshake, the tools, the catalogue
        for _ in range(CALLS):
            assert not (await robot.client.call_tool("look_around", {})).is_error
        await anyio.sleep(6)  # a model's turn: longer than httpx's and uvicorn's 5 s defaults
        assert not (await robot.client.call_tool("look_around", {})).is_error
    assert len(opened) == 1, opened
