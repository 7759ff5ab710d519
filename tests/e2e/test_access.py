"""Who may do what: the bearer token, Host/Origin checks, the session cap and idle timeout (a real
HTTP server process), one driver per robot (the lease), consent before acting, and the tool allowlist."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest
from mcp import Client
from mcp_types import ElicitRequestParams, ElicitResult

from robocog.server.app import build_server
from robocog.server.config import AccessConfig, SessionConfig
from robocog.server.robots.consent import NO_ELICITATION
from robocog.server.robots.ownership import ANONYMOUS, Driver, RobotBusy, RobotLease
from robocog.shared.errors import ConfigError
from robocog.shared.protocol import DRIVER_META_KEY
from tests.helpers import free_port, server_command

pytestmark = pytest.mark.anyio

TOKEN = "test-token-0123456789abcdef"
INITIALIZE = {
    "jsonrpc": "2.0",
    "id": 1,
    "method": "initialize",
    "params": {"protocolVersion": "2025-11-25", "capabilities": {}, "clientInfo": {"name": "probe", "version": "1"}},
}
ACCEPT = {"accept": "application/json, text/event-stream", "content-type": "application/json"}
BUSY = "driven by another session"  # the holder is a session
OTHER = "driven by another client"  # an in-process client, known by the name it gives
HANDLE_HOLDS = "driven by a client that passes robot_id"


def _wait_for_port(proc: subprocess.Popen[bytes], port: int, log: Path) -> None:
    deadline = time.monotonic() + 90  # a loaded CI machine starts PyBullet and Chroma slowly
    while time.monotonic() < deadline:
        assert proc.poll() is None, log.read_text()
        try:
            httpx.get(f"http://127.0.0.1:{port}/", timeout=0.5)
            return
        except httpx.TransportError:
            time.sleep(0.1)
    raise AssertionError(f"the server did not start: {log.read_text()}")


@pytest.fixture(scope="module")
def guarded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """One HTTP server with a token, a cap of 3 sessions and a 2-second idle timeout."""
    tmp = tmp_path_factory.mktemp("guarded")
    port = free_port()
    log = tmp / "server.log"
    with log.open("w") as out:
        proc = subprocess.Popen(
            [
                *server_command(),
                "--transport",
                "http",
                "--port",
                str(port),
                "--data-dir",
                str(tmp / "memory"),
                "--max-sessions",
                "3",
                "--session-idle-s",
                "2",
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**os.environ, "ANONYMIZED_TELEMETRY": "False", "ROBOCOG_AUTH_TOKEN": TOKEN},
        )
        try:
            _wait_for_port(proc, port, log)
            yield f"http://127.0.0.1:{port}/mcp"
        finally:
            proc.terminate()
            proc.wait(timeout=10)


def _post(url: str, body: Any = INITIALIZE, token: str | None = TOKEN, **headers: str) -> httpx.Response:
    auth = {"authorization": f"Bearer {token}"} if token else {}
    return httpx.post(url, json=body, headers={**ACCEPT, **auth, **headers}, timeout=10)


def _delete(url: str, session: str) -> None:
    httpx.delete(url, headers={"authorization": f"Bearer {TOKEN}", "mcp-session-id": session}, timeout=10)


def test_every_request_needs_the_bearer_token(guarded: str) -> None:
    assert _post(guarded, token=None).status_code == 401
    assert _post(guarded, token="wrong-token-0123456789abcdef").status_code == 401
    response = _post(guarded)
    assert response.status_code == 200
    _delete(guarded, response.headers["mcp-session-id"])


def test_the_bearer_scheme_is_read_in_any_case_by_the_server_and_the_router(guarded: str) -> None:
    from starlette.requests import Request

    from robocog.server.routing.router import Router

    for scheme in ("bearer", "BEARER", "Bearer"):  # RFC 7235: the scheme is case-insensitive
        response = _post(guarded, token=None, authorization=f"{scheme} {TOKEN}")
        assert response.status_code == 200, scheme
        _delete(guarded, response.headers["mcp-session-id"])
    router = Router([], token=TOKEN)

    def authorized(value: str) -> bool:
        return router._authorized(Request({"type": "http", "headers": [(b"authorization", value.encode())]}))

    assert all(authorized(f"{scheme} {TOKEN}") for scheme in ("bearer", "BEARER", "Bearer"))
    assert not any(authorized(v) for v in (f"Basic {TOKEN}", "Bearer wrong-token-0123456789ab", TOKEN, ""))


def test_foreign_origin_and_host_are_refused_even_with_the_token(guarded: str) -> None:
    assert _post(guarded, origin="http://evil.example").status_code == 403
    assert _post(guarded, host="evil.example").status_code == 421


def test_past_the_session_cap_a_new_session_gets_503_with_the_reason(guarded: str) -> None:
    sessions = []
    try:
        for _ in range(3):
            response = _post(guarded)
            assert response.status_code == 200
            sessions.append(response.headers["mcp-session-id"])
        refused = _post(guarded)
        assert refused.status_code == 503
        message = refused.json()["error"]["message"]
        assert "all 3 sessions are in use" in message and "--max-sessions" in message
        _delete(guarded, sessions.pop())
        again = _post(guarded)
        assert again.status_code == 200, "a closed session frees its place"
        sessions.append(again.headers["mcp-session-id"])
    finally:
        for session in sessions:
            _delete(guarded, session)


def test_an_idle_session_is_closed(guarded: str) -> None:
    response = _post(guarded)
    session = response.headers["mcp-session-id"]
    ping = {"jsonrpc": "2.0", "id": 2, "method": "ping"}
    time.sleep(3.5)
    assert _post(guarded, ping, **{"mcp-session-id": session}).status_code == 404


@asynccontextmanager
async def _http_client(url: str) -> AsyncIterator[Client]:
    import httpx2
    from mcp.client.streamable_http import streamable_http_client

    async with (
        httpx2.AsyncClient(headers={"authorization": f"Bearer {TOKEN}"}) as http,
        Client(streamable_http_client(url, http_client=http), mode="legacy") as client,
    ):
        yield client


async def test_one_http_session_drives_the_robot_until_it_leaves(guarded: str) -> None:
    async with _http_client(guarded) as a, _http_client(guarded) as b:
        assert not (await a.call_tool("move_to", {"location": "Kitchen Door"})).is_error
        refused = await b.call_tool("move_to", {"location": "Hallway Area Door"})
        assert refused.is_error and BUSY in refused.content[0].text  # type: ignore[union-attr]
        refused = await b.call_tool("add_to_scratchpad", {"text": "mine"})
        assert refused.is_error and BUSY in refused.content[0].text  # type: ignore[union-attr]
        assert not (await b.call_tool("look_around", {})).is_error, "watching is open to all"
        await b.read_resource("robocog://world/state")
    # a has gone (its session deleted): the robot is free
    async with _http_client(guarded) as c:
        for _ in range(50):  # the session's connection closes just after its DELETE is answered
            moved = await c.call_tool("move_to", {"location": "Hallway Area Door"})
            if not moved.is_error:
                break
            await anyio.sleep(0.1)
        assert not moved.is_error, moved.content


def test_binding_beyond_loopback_without_a_token_refuses_to_start() -> None:
    env = {k: v for k, v in os.environ.items() if k != "ROBOCOG_AUTH_TOKEN"}
    done = subprocess.run(
        [*server_command(), "--transport", "http", "--host", "0.0.0.0"], capture_output=True, text=True, env=env
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("robocog-server: --host 0.0.0.0") and "--auth-token" in lines[0]


# --- in process: the lease, consent, the allowlist --------------------------------------------------------


def test_the_lease_ends_after_a_sessionless_driver_goes_quiet() -> None:

    now = [0.0]
    lease = RobotLease(idle_s=10, clock=lambda: now[0])
    a, b = Driver(("driver", "a"), "a", None), Driver(("driver", "b"), "b", None)
    lease.claim(a)
    now[0] = 9.0
    with pytest.raises(RobotBusy, match="lets go 10 s after its last call"):
        lease.claim(b)
    lease.claim(a)  # a acts again: its lease runs on
    now[0] = 18.0
    with pytest.raises(RobotBusy):
        lease.claim(b)
    now[0] = 19.5
    lease.claim(b)
    assert lease.holder is b


def test_a_handle_takes_the_robot_from_the_anonymous_driver_and_keeps_it() -> None:
    now = [0.0]
    lease = RobotLease(idle_s=600, clock=lambda: now[0])
    anonymous = Driver(ANONYMOUS, "a client without a robot_id", None, anonymous=True)
    handle = Driver(("driver", "h"), "robot h", None, "h")
    other = Driver(("driver", "o"), "robot o", None, "o")
    assert lease.claim(anonymous), "the free robot is taken"
    assert not lease.claim(anonymous), "and held"
    assert lease.claim(handle), "a handle presented takes it over from the anonymous driver"
    with pytest.raises(RobotBusy, match="passes robot_id"):
        lease.claim(anonymous)  # an id-less call may read, not act
    with pytest.raises(RobotBusy, match=HANDLE_HOLDS):
        lease.claim(other)  # another handle waits its turn
    now[0] = 599.0
    with pytest.raises(RobotBusy):
        lease.claim(anonymous)
    now[0] = 1200.0  # the handle has been silent for its idle time: it let go
    assert lease.claim(anonymous)
    now[0] = 1229.0
    with pytest.raises(RobotBusy, match="lets go 30 s after its last call"):
        lease.claim(Driver(("session", "s"), "inspector (HTTP session)", None))
    now[0] = 1231.0  # the anonymous driver keeps the robot 30 s at most
    assert lease.claim(other)


def _config(tmp_path: Path) -> SessionConfig:
    return SessionConfig(seed=0, data_dir=tmp_path / "memory")


async def test_sessionless_clients_are_told_apart_by_their_driver_name(tmp_path: Path) -> None:
    server = build_server(_config(tmp_path))
    async with Client(server) as client:  # protocol 2026-07-28: no session
        ours = {DRIVER_META_KEY: "run-1"}
        assert not (await client.call_tool("move_to", {"location": "Hallway Area Door"}, meta=ours)).is_error  # type: ignore[arg-type]
        assert not (await client.call_tool("move_to", {"location": "Kitchen Door"}, meta=ours)).is_error  # type: ignore[arg-type]
        theirs = {DRIVER_META_KEY: "run-2"}
        refused = await client.call_tool("move_to", {"location": "Hallway Area Door"}, meta=theirs)  # type: ignore[arg-type]
        assert refused.is_error and OTHER in refused.content[0].text  # type: ignore[union-attr]


def _answering(decision: str | None, asked: list[str]) -> Any:
    async def answer(context: Any, params: ElicitRequestParams) -> ElicitResult:
        asked.append(params.message)
        if decision is None:
            return ElicitResult(action="decline")
        return ElicitResult(action="accept", content={"decision": decision})

    return answer


async def _where(client: Client) -> str:
    state = await client.call_tool("look_around", {})
    assert state.structured_content is not None
    return str(state.structured_content["location"])


@pytest.mark.parametrize("mode", ["legacy", "auto"])
async def test_confirm_actions_asks_the_user_before_the_robot_moves(tmp_path: Path, mode: str) -> None:
    server = build_server(_config(tmp_path), access=AccessConfig(confirm_actions=True))
    asked: list[str] = []
    async with Client(server, mode=mode, elicitation_callback=_answering("allow once", asked)) as client:
        assert not (await client.call_tool("move_to", {"location": "Hallway Area Door"})).is_error
        assert await _where(client) == "Hallway Area Door"
        assert not (await client.call_tool("move_to", {"location": "Kitchen Door"})).is_error
        assert len(asked) == 2 and "move_to(location='Hallway Area Door')" in asked[0]
        assert not (await client.call_tool("look_around", {})).is_error and len(asked) == 2, "reading never asks"


async def test_allow_for_this_session_asks_once_and_deny_leaves_the_robot_still(tmp_path: Path) -> None:
    server = build_server(_config(tmp_path), access=AccessConfig(confirm_actions=True))
    asked: list[str] = []
    async with Client(server, mode="legacy", elicitation_callback=_answering("allow for this session", asked)) as a:
        for location in ("Hallway Area Door", "Kitchen Door", "Hallway Area Door"):
            assert not (await a.call_tool("move_to", {"location": location})).is_error
        assert len(asked) == 1
    denied: list[str] = []
    async with Client(server, mode="legacy", elicitation_callback=_answering("deny", denied)) as b:
        before = await _where(b)
        refused = await b.call_tool("move_to", {"location": "Living Room Door"})
        assert refused.is_error and "did not allow move_to" in refused.content[0].text  # type: ignore[union-attr]
        assert await _where(b) == before
    async with Client(server, mode="legacy", elicitation_callback=_answering(None, [])) as c:
        assert (await c.call_tool("grab", {"object": "cube"})).is_error, "declining is denying"


async def test_confirm_actions_with_a_client_that_cannot_ask_says_what_to_do(tmp_path: Path) -> None:
    server = build_server(_config(tmp_path), access=AccessConfig(confirm_actions=True))
    async with Client(server, mode="legacy") as client:
        refused = await client.call_tool("move_to", {"location": "Hallway Area Door"})
        assert refused.is_error and refused.content[0].text.endswith(NO_ELICITATION)  # type: ignore[union-attr]
        assert "without --confirm-actions" in NO_ELICITATION


async def test_allow_tools_publishes_only_those_tools(tmp_path: Path) -> None:
    server = build_server(_config(tmp_path), access=AccessConfig(allow_tools=frozenset({"look_around", "end_task"})))
    async with Client(server) as client:
        assert sorted(t.name for t in (await client.list_tools()).tools) == ["end_task", "look_around"]
        refused = await client.call_tool("move_to", {"location": "Hallway Area Door"})
        assert refused.is_error
    with pytest.raises(ConfigError, match="no tool called fly"):
        build_server(_config(tmp_path), access=AccessConfig(allow_tools=frozenset({"fly"})))
