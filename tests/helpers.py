"""What several test modules share: the tool names, the paper's map and tasks, snapshot checking, and
how to start a real server process (its command line, a free loopback port, a stdio transport).

Test modules import from here, never from one another nor from the code under test, so that the
expectations stay written down once and independent of the code they check.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robocog.shared.paper import T1_SEQUENCE, T2_SEQUENCE, Action, action_args

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
# robocog.shared.paper; re-exported here for the tests.


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


@contextmanager
def http_server(log: Path, *args: str, timeout_s: float = 60) -> Iterator[str]:
    """`robocog-server --transport http ARGS` on a free loopback port, its output in `log`; yields
    its /mcp URL once it listens, and checks at the end that it is still running (then stops it)."""
    port = free_port()
    with log.open("wb") as out:
        proc = subprocess.Popen(
            [*server_command(), "--transport", "http", "--port", str(port), *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            env=server_env(),
        )
        try:
            deadline = time.monotonic() + timeout_s
            while True:
                assert proc.poll() is None, log.read_text(errors="replace")
                assert time.monotonic() < deadline, f"the HTTP server did not listen within {timeout_s:g} s"
                with socket.socket() as s:
                    if s.connect_ex(("127.0.0.1", port)) == 0:
                        break
                time.sleep(0.1)
            yield f"http://127.0.0.1:{port}/mcp"
            assert proc.poll() is None, log.read_text(errors="replace")
        finally:
            proc.terminate()
            proc.wait(timeout=30)


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
