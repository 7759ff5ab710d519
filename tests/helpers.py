"""What several test modules share: the tool names, the paper's map and tasks, snapshot checking, and
how to start a real server process (its command line, a free loopback port, a stdio transport, an
HTTP server and its process, one with its live viewer) and talk to it (an SDK session over HTTP, or
raw JSON-RPC posts as a client without the SDK sends them); the benches use it too.

Test modules import from here, never from one another nor from the code under test, so that the
expectations stay written down once and independent of the code they check.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from contextlib import asynccontextmanager, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, cast

from robocog.server.world.paper import T1_SEQUENCE, T2_SEQUENCE, Action, action_args

if TYPE_CHECKING:  # the benches run this file with a previous release's install too
    from mcp import Client

    from robocog.agent.client.connection import Robot
    from robocog.agent.client.protocols import McpClient

__all__ = ["T1_SEQUENCE", "T2_SEQUENCE", "Action", "action_args"]

SNAPSHOTS = Path(__file__).parent / "snapshots"

#: The tools a model is offered, in every profile.
ROBOT_TOOLS = frozenset(
    {
        "look_around",
        "move_to",
        "grab",
        "place",
        "add_to_scratchpad",
        "view_scratchpad",
        "end_task",
        "search_memory",
        "look",
        "open",
        "close",
    }
)

#: The eval profile's controls for harnesses; never offered to a model.
CONTROL_TOOLS = frozenset({"reset_world", "begin_task", "check_task", "clear_memory"})

#: The robot app's own tool (every profile, unless --no-app); never offered to a model.
APP_TOOLS = frozenset({"robot_view"})

# --- the paper's semantic map (BRIEF.md, "The world") --------------------------------------------

PAPER_EDGES = [
    ("Hallway Area Door", "Front Door"),
    ("Hallway Area Door", "Kitchen Door"),
    ("Hallway Area Door", "Living Room Door"),
    ("Kitchen Area Left", "Kitchen Door"),
    ("Kitchen Area Left", "Kitchen Shelf"),
    ("Kitchen Area Left", "Kitchen Table"),
    ("Living Room", "Living Room Door"),
    ("Living Room", "Living Room TV"),
]
PAPER_LOCATIONS = {
    "Front Door": (0.0, 0.0),
    "Hallway Area Door": (3.0, 0.0),
    "Kitchen Door": (3.0, 2.0),
    "Living Room Door": (3.0, -2.0),
    "Living Room": (4.0, -4.0),
    "Living Room TV": (8.0, -4.5),
    "Kitchen Area Left": (3.0, 4.0),
    "Kitchen Shelf": (1.0, 4.85),
    "Kitchen Table": (6.0, 5.0),
}
#: The place positions of each location that has any.
PAPER_POSITIONS = {
    "Kitchen Shelf": {"top", "middle", "bottom"},
    "Kitchen Table": {"middle"},
    "Front Door": {"floor"},
    "Hallway Area Door": {"floor"},
    "Living Room": {"floor"},
    "Kitchen Area Left": {"floor"},
}

#: The tests' folder, its data files, and the repository's root.
TESTS_DIR = Path(__file__).resolve().parent
DATA = TESTS_DIR / "data"
ROOT = TESTS_DIR.parent

# --- the paper's tasks ---------------------------------------------------------------------------

T1 = "Put away all the items into the shelf."
T2 = "Swap the mug and the cube in the shelf."

# The paper's action scripts (T1_SEQUENCE, T2_SEQUENCE, action_args) are written once, in
# robocog.server.world.paper; re-exported here for the tests.


# --- snapshots -----------------------------------------------------------------------------------


#: The published MCP contract, one file per profile, shipped in the package (robocog.assets.contract).
CONTRACT_DIR = Path(__file__).resolve().parent.parent / "assets" / "contract"


def check_snapshot(name: str | Path, value: dict[str, Any]) -> None:
    """`value` equals tests/snapshots/NAME.json (or the file at the path `name`);
    ROBOCOG_UPDATE_SNAPSHOTS=1 rewrites the file first."""
    path = name if isinstance(name, Path) else SNAPSHOTS / f"{name}.json"
    text = json.dumps(value, indent=2, sort_keys=True) + "\n"
    if os.environ.get("ROBOCOG_UPDATE_SNAPSHOTS") == "1":
        path.parent.mkdir(exist_ok=True)
        path.write_text(text, encoding="utf-8")
    assert path.exists(), f"no snapshot {path}; run with ROBOCOG_UPDATE_SNAPSHOTS=1 to create it"
    assert json.loads(text) == json.loads(path.read_text(encoding="utf-8")), (
        f"the MCP contract changed; if deliberate, update {path} with ROBOCOG_UPDATE_SNAPSHOTS=1"
    )


# --- real server processes ---------------------------------------------------------------------------


def server_command() -> list[str]:
    """The installed console script beside this Python, or the module when run from a bare checkout."""
    script = shutil.which("robocog-server", path=str(Path(sys.executable).parent))
    return [script] if script else [sys.executable, "-m", "robocog.server.cli"]


def free_port() -> int:
    """A TCP port free on loopback right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def stdio_params(*args: str) -> Any:
    """A stdio transport to a spawned server, whose stderr (PyBullet's chatter) goes to a log."""
    from mcp.client.stdio import StdioServerParameters, stdio_client

    command, *rest = server_command()
    params = StdioServerParameters(command=command, args=[*rest, *args], env={"ANONYMIZED_TELEMETRY": "False"})
    return stdio_client(params, errlog=tempfile.TemporaryFile("w+"))


def server_env() -> dict[str, str]:
    """The environment for a spawned server: without a token a developer may have set, no telemetry."""
    return {k: v for k, v in os.environ.items() if k != "ROBOCOG_AUTH_TOKEN"} | {"ANONYMIZED_TELEMETRY": "False"}


def installed_env() -> dict[str, str]:
    """The environment for timing another install's commands as a user runs them: bytecode written
    (make exports PYTHONDONTWRITEBYTECODE, and an install without bytecode would compile on every
    start, which no user's does), LiteLLM's local cost map, no telemetry."""
    kept = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return kept | {"LITELLM_LOCAL_MODEL_COST_MAP": "True", "ANONYMIZED_TELEMETRY": "False"}


@contextmanager
def http_server_process(
    log: Path, *args: str, timeout_s: float = 60, env: dict[str, str] | None = None, command: list[str] | None = None
) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """`robocog-server --transport http ARGS` (or `command`'s, another install's) on a free loopback
    port, its output in `log` (and `env` over `server_env()`); yields its /mcp URL and its process
    once it listens, then stops it."""
    port = free_port()
    with log.open("wb") as out:
        proc = subprocess.Popen(
            [*(command or server_command()), "--transport", "http", "--port", str(port), *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            env=server_env() | (env or {}),
        )
        try:
            deadline = time.monotonic() + timeout_s
            while not listening(port):
                assert proc.poll() is None, log.read_text(errors="replace")[-3000:]
                assert time.monotonic() < deadline, f"the HTTP server did not listen within {timeout_s:g} s"
                time.sleep(0.1)
            yield f"http://127.0.0.1:{port}/mcp", proc
        finally:
            proc.terminate()
            proc.wait(timeout=60)


@contextmanager
def http_server(log: Path, *args: str, timeout_s: float = 60) -> Iterator[str]:
    """`http_server_process`'s URL, and a check at the end that the server is still running."""
    with http_server_process(log, *args, timeout_s=timeout_s) as (url, proc):
        yield url
        assert proc.poll() is None, log.read_text(errors="replace")


def listening(port: int) -> bool:
    """Whether something accepts connections on loopback's `port`."""
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def rss_mb(pid: int) -> float:
    """A process's resident memory, in MB (Linux)."""
    return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * 4096 / 1e6


def fleet_processes(router: int) -> list[int]:
    """A router's fleet processes (its children that are robocog servers, not `chroma run`)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(stat.read_text().rsplit(")", 1)[-1].split()[1])
            cmdline = (stat.parent / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        if ppid == router and b"robocog.server.cli" in cmdline:
            found.append(int(stat.parent.name))
    return sorted(found)


@asynccontextmanager
async def http_session(url: str) -> AsyncIterator[Client]:
    """An MCP session (the SDK's client, initialize handshake) over HTTP: one driver."""
    from mcp import Client
    from mcp.client.streamable_http import streamable_http_client

    async with Client(streamable_http_client(url), mode="legacy") as client:
        yield client


@asynccontextmanager
async def in_process_robot(data_dir: Path) -> AsyncIterator[Robot]:
    """The robot of an in-process eval-profile server (memory under `data_dir`), as the agent loop
    sees it: its client, tools and system prompt."""
    from mcp import Client

    from robocog.agent.client.connection import Robot
    from robocog.server.app import build_server
    from robocog.server.config import SessionConfig

    server = build_server(SessionConfig(data_dir=data_dir), profile="eval")
    async with Client(server) as client:
        tools = (await client.list_tools()).tools
        prompt = await client.get_prompt("robot_system")
        yield Robot(client, tools, prompt.messages[0].content.text, {}, "in-memory")  # type: ignore[union-attr]


async def call_ok(client: McpClient, tool: str, **arguments: Any) -> dict[str, Any]:
    """Call a tool that must succeed; its structured result."""
    result = await client.call_tool(tool, arguments)
    assert not result.is_error, result.content
    assert isinstance(result.structured_content, dict)
    return dict(result.structured_content)


#: An `initialize` request as a client without the SDK posts it, and the headers of such posts.
INITIALIZE = {
    "jsonrpc": "2.0",
    "id": 1,
    "method": "initialize",
    "params": {"protocolVersion": "2025-11-25", "capabilities": {}, "clientInfo": {"name": "probe", "version": "1"}},
}
HEADERS = {"accept": "application/json, text/event-stream", "content-type": "application/json"}


def raw_initialize(url: str) -> Any:
    """POST `initialize` (and, when it is answered 200, `notifications/initialized`) with httpx: the
    answer, whose `mcp-session-id` header names the session."""
    import httpx

    answer = httpx.post(url, json=INITIALIZE, headers=HEADERS, timeout=30)
    if answer.status_code == 200:
        headers = HEADERS | {"mcp-session-id": answer.headers["mcp-session-id"], "mcp-protocol-version": "2025-11-25"}
        httpx.post(url, json={"jsonrpc": "2.0", "method": "notifications/initialized"}, headers=headers, timeout=30)
    return answer


def raw_call(url: str, sid: str, tool: str, **arguments: Any) -> str:
    """POST `tools/call` on session `sid` with httpx: the answer's status code and text."""
    answer = raw_answer(url, sid, tool, **arguments)
    return f"{answer.status_code} {answer.text}"


def raw_answer(url: str, sid: str, tool: str, **arguments: Any) -> Any:
    """POST `tools/call` on session `sid` with httpx: the answer."""
    import httpx

    headers = HEADERS | {"mcp-session-id": sid, "mcp-protocol-version": "2025-11-25"}
    message = {"jsonrpc": "2.0", "id": 2, "method": "tools/call", "params": {"name": tool, "arguments": arguments}}
    return httpx.post(url, json=message, headers=headers, timeout=60)


@asynccontextmanager
async def live_server(data_dir: Path, *args: str) -> AsyncIterator[tuple[Client, str]]:
    """A real `robocog-server --view 0 ARGS` over stdio (an MCP client), and its viewer's address."""
    import anyio
    from mcp import Client
    from mcp.client.stdio import StdioServerParameters, stdio_client

    command, *rest = server_command()
    argv = [*rest, *args, "--view", "0", "--data-dir", str(data_dir)]
    with tempfile.NamedTemporaryFile("w+", suffix=".log") as log:
        params = StdioServerParameters(command=command, args=argv, env={"ANONYMIZED_TELEMETRY": "False"})
        async with Client(stdio_client(params, errlog=cast(TextIO, log))) as client:
            url = None
            with anyio.fail_after(60):
                while url is None:
                    found = re.search(r"live viewer at (http://127\.0\.0\.1:\d+/)", Path(log.name).read_text())
                    url = found.group(1) if found else None
                    await anyio.sleep(0.05)
            yield client, url


#: The environment of a local Ray cluster: nothing phones home.
RAY_ENV = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "ANONYMIZED_TELEMETRY": "False"}


@contextmanager
def ray_cluster(timeout_s: float = 90) -> Iterator[str]:
    """A one-node Ray cluster on loopback, as `ray start --head --block` makes it (its own ports, its
    own temporary directory); yields its address, then stops it by ending the process group that
    `ray start --block` leads (SIGTERM lets it stop what it started; what lingers goes with SIGKILL)."""
    import signal

    temp = Path(tempfile.mkdtemp(prefix="rc-ray-"))  # short: Ray's socket paths must stay under 108 bytes
    port = free_port()
    command = [
        *(str(Path(sys.executable).parent / "ray"), "start", "--head", "--block"),
        *("--node-ip-address", "127.0.0.1", "--port", str(port), "--num-cpus", "2"),
        *("--include-dashboard=false", "--disable-usage-stats", "--temp-dir", str(temp)),
        *("--ray-client-server-port", str(free_port()), "--dashboard-port", str(free_port())),
        *("--dashboard-agent-listen-port", str(free_port())),
    ]
    log = temp / "ray-start.log"
    with log.open("w") as out:
        proc = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=RAY_ENV, start_new_session=True)
    try:
        deadline = time.monotonic() + timeout_s
        while "Ray runtime started" not in log.read_text(errors="replace"):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("ray start failed:\n" + log.read_text(errors="replace")[-3000:])
            time.sleep(0.2)
        yield f"127.0.0.1:{port}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        shutil.rmtree(temp, ignore_errors=True)


#: Answers one raw HTTP request (its head and body) on the connection's writer.
Handler = Callable[[bytes, asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]


@asynccontextmanager
async def served(handler: Handler) -> AsyncIterator[str]:
    """A raw HTTP/1.1 server on loopback that reads each request's head and body and lets `handler`
    answer it; yields its /mcp URL."""

    async def connection(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            while True:
                head = await reader.readuntil(b"\r\n\r\n")
                length = 0
                for line in head.split(b"\r\n"):
                    if line.lower().startswith(b"content-length:"):
                        length = int(line.split(b":")[1])
                await handler(head + await reader.readexactly(length), reader, writer)
        except (asyncio.IncompleteReadError, ConnectionError):
            pass
        finally:
            writer.close()

    server = await asyncio.start_server(connection, "127.0.0.1", 0)
    async with server:
        yield f"http://127.0.0.1:{server.sockets[0].getsockname()[1]}/mcp"
