"""Reaching the robot: spawn `robocog-server` over stdio (default), or connect over streamable HTTP.

The client never imports `robocog.server`: it speaks MCP to whatever the command line or URL gives.
"""

from __future__ import annotations

import functools
import json
import os
import shlex
import shutil
import ssl
import sys
import tempfile
from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, TextIO, cast

from mcp import Client
from mcp.client import Transport
from mcp.client.stdio import StdioServerParameters
from mcp.shared.exceptions import MCPError
from mcp_types import CONNECTION_CLOSED, Tool

from robocog.agent.client.protocols import Channel, McpClient
from robocog.shared import __version__
from robocog.shared.errors import ServerConnectionError
from robocog.shared.protocol import CONTRACT_VERSION_PATTERN, FLEET_FULL
from robocog.shared.provenance import PHYSICS_PATTERN
from robocog.shared.web import CLIENT_KEEP_ALIVE_S


def default_server_command() -> list[str]:
    """`robocog-server` next to this Python, else on PATH, else the module."""
    beside = Path(sys.executable).parent / "robocog-server"
    if beside.exists():
        return [str(beside)]
    found = shutil.which("robocog-server")
    return [found] if found else [sys.executable, "-m", "robocog.server.cli"]


@dataclass
class ServerSpec:
    """How to reach the server: `url` for HTTP, else a command line spawned over stdio."""

    url: str | None = None
    command: list[str] = field(default_factory=default_server_command)
    extra_args: list[str] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)
    #: The bearer token of an HTTP server started with --auth-token (default: $ROBOCOG_AUTH_TOKEN).
    auth_token: str | None = field(default_factory=lambda: os.environ.get("ROBOCOG_AUTH_TOKEN") or None)
    #: A server the harness started itself (a worker's `robocog-server`, or a fleet it started with
    #: --json-response, whose every POST is answered with one JSON body): robocog's lean client
    #: (`lean`) in place of the SDK's.
    lean: bool = False

    @classmethod
    def from_options(cls, url: str | None, server_cmd: str | None, extra_args: list[str] | None = None) -> ServerSpec:
        command = shlex.split(server_cmd) if server_cmd else default_server_command()
        return cls(url=url, command=command, extra_args=extra_args or [])

    @property
    def label(self) -> str:
        return self.url or shlex.join(self.command + self.extra_args)


@dataclass
class Robot:
    """A connected MCP client plus what the run needs from the server."""

    client: McpClient  # the SDK's `Client`, or robocog's lean one (`ServerSpec.lean`)
    tools: list[Tool]
    system_prompt: str
    tasks: dict[str, str]  # task id -> prompt (from robocog://tasks)
    label: str
    requires: dict[str, list[str]] = field(default_factory=dict)  # task id -> tasks that must succeed first
    catalogue: dict[str, dict[str, Any]] = field(default_factory=dict)  # task id -> its robocog://tasks entry
    contract: str | None = None  # the MCP contract version the server announces in its instructions
    physics: str | None = None  # the physics build it announces there ("pybullet 3.2.7")
    #: Whether the world the last reset_world made has furniture that opens (its answer lists some);
    #: None while no reset through the harness's controls has answered.
    furniture: bool | None = None

    _prompts: dict[str, str] = field(default_factory=dict)

    async def prompt(self, name: str) -> str:
        """The text of the server's prompt `name` (fetched once); `robot_system` is fetched at connect."""
        if name == "robot_system":
            return self.system_prompt
        if name not in self._prompts:
            result = await self.client.get_prompt(name)
            self._prompts[name] = "\n".join(getattr(m.content, "text", "") for m in result.messages)
        return self._prompts[name]

    async def claim(self) -> None:
        """Take this client's robot before the model starts (reading the semantic map binds it, as a
        tool call would): when a fleet has no robot free, `ServerConnectionError` with the server's
        own sentence, so a full fleet is never mistaken for the model's failure."""
        try:
            await self.client.read_resource("robocog://world/map")
            return
        except Exception:  # a resource error hides its reason: a read-only tool call that fails says it
            result = await self.client.call_tool("view_scratchpad", {})
        text = " ".join(getattr(block, "text", "") for block in result.content)
        if result.is_error and FLEET_FULL in text:
            reason = text.removeprefix("Error executing tool view_scratchpad: ")
            raise ServerConnectionError(f"the robot server at {self.label}: {reason}")
        # any other answer is the model's to meet on its first call, as before

    @property
    def can_check(self) -> bool:
        return any(t.name == "check_task" for t in self.tools)

    def task_id_for(self, prompt: str) -> str | None:
        wanted = " ".join(prompt.split()).casefold()
        return next((tid for tid, text in self.tasks.items() if " ".join(text.split()).casefold() == wanted), None)


def spawn_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a server this client spawns: no telemetry, the caller's `ROBOCOG_*`
    settings, then `extra`."""
    return {
        "ANONYMIZED_TELEMETRY": "False",
        **{k: v for k, v in os.environ.items() if k.startswith("ROBOCOG_")},
        **(extra or {}),
    }


class ServerLog:
    """A spawned server's stderr, in a temporary file (its start-up chatter stays off the terminal):
    its last lines quoted when the server fails; the file is deleted when closed."""

    def __init__(self, prefix: str) -> None:
        self.file: IO[str] = tempfile.NamedTemporaryFile("w+", prefix=prefix, suffix=".log", delete=False)  # noqa: SIM115

    def tail(self, lines: int) -> str:
        """The last `lines` lines written so far."""
        self.file.flush()
        return "\n".join(Path(self.file.name).read_text(encoding="utf-8", errors="replace").splitlines()[-lines:])

    def close(self) -> None:
        self.file.close()
        Path(self.file.name).unlink(missing_ok=True)


def leaf_message(exc: BaseException) -> str:
    """The innermost message of an exception (task groups wrap the real one)."""
    while isinstance(exc, BaseExceptionGroup) and exc.exceptions:
        exc = exc.exceptions[0]
    return f"{type(exc).__name__}: {exc}"


def unreachable(exc: BaseException) -> bool:
    """Whether `exc` is a request's failure because its server could not be reached: `CONNECTION_CLOSED`,
    as the SDK's session raises when its connection closes and `json_http` when a POST cannot
    reach the server."""
    return isinstance(exc, MCPError) and exc.error.code == CONNECTION_CLOSED


@asynccontextmanager
async def connect(spec: ServerSpec) -> AsyncIterator[Robot]:
    """Connect, list the tools, fetch the system prompt and the task catalogue.

    A server the user names (`--url`, `--server-cmd`) is reached through the official SDK's `Client`;
    a server the study started itself (`spec.lean`: a worker's `robocog-server` over stdio, a fleet
    answering in JSON over plain HTTP) through robocog's lean client (`lean`).

    A spawned server's stderr goes to a log file, so its start-up chatter stays off the terminal;
    if the server fails, the error quotes the end of that log.
    """
    log: ServerLog | None = None
    session: AbstractAsyncContextManager[Robot]
    if spec.lean and spec.url and spec.url.lower().startswith("http://"):
        from robocog.agent.client.json_http import json_http_channel

        channel = json_http_channel(spec.url, spec.auth_token, keepalive_s=CLIENT_KEEP_ALIVE_S)
        session = _lean_session(channel, spec)
    elif spec.url:
        session = _session(_http_transport(spec.url, spec.auth_token), spec)
    elif spec.lean and os.name == "posix":  # a process group of its own to end (see `lean.stdio_channel`)
        from robocog.agent.client.lean import stdio_channel

        log = ServerLog("robocog-server-")
        argv = [*spec.command, *spec.extra_args]
        session = _lean_session(stdio_channel(argv, spawn_env(spec.env), log.file, spec.label), spec)
    else:
        from mcp.client.stdio import stdio_client

        command, *args = spec.command
        params = StdioServerParameters(command=command, args=[*args, *spec.extra_args], env=spawn_env(spec.env))
        log = ServerLog("robocog-server-")
        session = _session(stdio_client(params, errlog=cast(TextIO, log.file)), spec)  # a text file, deleted after
    try:
        async with session as robot:
            yield robot
    except Exception as exc:
        if log is None or isinstance(exc, ServerConnectionError):
            raise
        tail = log.tail(15)
        where = f"; the end of its log:\n{tail}" if tail.strip() else " (it wrote nothing to stderr)"
        raise ServerConnectionError(f"the robot server `{spec.label}` failed: {leaf_message(exc)}{where}") from exc
    finally:
        if log is not None:
            log.close()


@functools.cache
def tls_context() -> ssl.SSLContext:
    """httpx's default TLS context (its CA bundle), made once per process and shared by every client
    robocog makes: httpx makes one per client otherwise, about 45 ms of CPU at every connection (a
    study of 64 workers makes 64 at its start). The fleets' channel takes plain HTTP and never uses it."""
    import httpx2  # the MCP SDK's HTTP client

    return httpx2.create_ssl_context()


@asynccontextmanager
async def _http_transport(url: str, token: str | None) -> AsyncIterator[Any]:
    """The SDK's streamable HTTP transport to `url` as it comes, sending the bearer token when there is one.

    The SDK reads a request's answer from the POST's event stream and closes the response as soon as
    the answer's event has arrived (`mcp/client/streamable_http.py`, `_handle_sse_response`), before
    the bytes that end the stream; httpx reuses a connection only when its exchange is done, so over
    event streams every call opens a connection of its own. robocog once read each stream to its end
    to keep the connection (and sent the bytes through aiohttp). It no longer matters: a server a user
    names takes the SDK as it is (a new connection costs a call about a millisecond of CPU on loopback:
    `make bench --only http`), and the fleets a study starts answer in JSON, which ends each exchange,
    through the lean client's channel (`json_http`), whose connection lasts the attempt.
    """
    import httpx2  # the MCP SDK's HTTP client
    from mcp.client.streamable_http import streamable_http_client

    from robocog.agent.client.json_http import CONNECT_TIMEOUT_S, READ_TIMEOUT_S, refused_sentence

    headers = {"Authorization": f"Bearer {token}"} if token else {}

    async def refused(response: httpx2.Response) -> None:
        if response.status_code == 401:
            raise ServerConnectionError(refused_sentence(url, token))

    # The SDK's own timeouts (a response stream may stay open for minutes); an idle connection kept
    # through the model's turns (httpx's 5 s default dropped it between most calls of JSON answers).
    timeout = httpx2.Timeout(CONNECT_TIMEOUT_S, read=READ_TIMEOUT_S)
    limits = httpx2.Limits(keepalive_expiry=CLIENT_KEEP_ALIVE_S)
    hooks = {"response": [refused]}
    async with (
        httpx2.AsyncClient(
            headers=headers, timeout=timeout, limits=limits, event_hooks=hooks, verify=tls_context()
        ) as client,
        streamable_http_client(url, http_client=client) as streams,
    ):
        yield streams


@asynccontextmanager
async def _session(target: Transport, spec: ServerSpec) -> AsyncIterator[Robot]:
    """The robot over the SDK's `Client` on `target` (a transport)."""
    from mcp_types import Implementation

    from robocog.agent.client.output_schemas import share_validators

    # Over HTTP, the initialize handshake: the server then knows this client by its session (the robot's
    # lease, its per-session state); the sessionless 2026-07-28 protocol would make every call a stranger.
    mode = "legacy" if spec.url else "auto"
    async with Client(target, client_info=Implementation(name="robocog", version=__version__), mode=mode) as client:
        tools = (await client.list_tools()).tools
        share_validators(client.session, tools)  # compiled once per process, not per session
        yield await _robot(client, tools, spec)


@asynccontextmanager
async def _lean_session(channel: AbstractAsyncContextManager[Channel], spec: ServerSpec) -> AsyncIterator[Robot]:
    """The robot over robocog's lean client on `channel` (an async context manager that opens it),
    with the initialize handshake (protocol 2025-11-25: see `lean`)."""
    from mcp_types import Implementation

    from robocog.agent.client.lean import LeanClient

    info = Implementation(name="robocog", version=__version__)
    async with channel as opened, LeanClient(opened, client_info=info, name=spec.label) as client:
        tools = (await client.list_tools()).tools
        yield await _robot(client, tools, spec)


async def _robot(client: McpClient, tools: list[Tool], spec: ServerSpec) -> Robot:
    """What the run needs from the server behind `client`: the system prompt, the task catalogue, the
    contract version and the physics build its instructions announce."""
    prompt = await client.get_prompt("robot_system")
    system_prompt = "\n".join(getattr(m.content, "text", "") for m in prompt.messages)
    tasks: dict[str, str] = {}
    requires: dict[str, list[str]] = {}
    entries: dict[str, dict[str, Any]] = {}
    try:
        catalogue = await client.read_resource("robocog://tasks")
        for item in json.loads(getattr(catalogue.contents[0], "text", "[]")):
            tasks[item["id"]] = item["prompt"]
            requires[item["id"]] = [str(r) for r in item.get("requires") or []]
            entries[item["id"]] = item
    except Exception:  # a server without the catalogue can still be driven
        tasks, requires, entries = {}, {}, {}
    announced = CONTRACT_VERSION_PATTERN.search(client.instructions or "")
    physics = PHYSICS_PATTERN.search(client.instructions or "")
    return Robot(
        client=client,
        tools=tools,
        system_prompt=system_prompt,
        tasks=tasks,
        label=spec.label,
        requires=requires,
        catalogue=entries,
        contract=announced.group(1) if announced else None,
        physics=physics.group(1) if physics else None,
    )
