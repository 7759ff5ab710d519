"""`robocog-server`'s options: the parser, its help, and the checks of each option's value (a port,
a positive number, a tool list, the processes, search_k) that argparse reports in one line."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from pathlib import Path

from robocog.server.config import DEFAULT_MAX_SESSIONS, DEFAULT_SESSION_IDLE_S
from robocog.shared.cli_parser import OneLineParser

DESCRIPTION = """\
A simulated household robot (PyBullet) behind the Model Context Protocol.

One server is one robot (or, with --robots N over HTTP, a fleet: a robot per session): a mobile
manipulator in a kitchen, hallway and living room, with an episodic memory (ChromaDB, embedded by
default) and a scratchpad. Tools: look_around, move_to, grab, place, add_to_scratchpad,
view_scratchpad, end_task, search_memory; with --profile eval also the harness controls reset_world
(with search_k, memory_labels, memory_namespace), begin_task (an episode per task, optionally
keeping the scratchpad), check_task and clear_memory. Resources: robocog://world/state,
robocog://world/map, robocog://world/description (the world in words, as the paper's task message
gives it), robocog://world/image, robocog://tasks; templates robocog://objects/{name} and
robocog://locations/{name}. Prompts: robot_system, robot_system_paper (the paper's protocol), T1,
T2, bring(object, location). Names complete from the scene (completion/complete); clients may set a
log level (logging/setLevel) and subscribe to the world's resources (resources/subscribe).
"""


EPILOG = """\
examples:
  robocog-server                                  # stdio, for Claude Desktop, Cursor, the MCP Inspector
  robocog-server --transport http --port 8765     # streamable HTTP on http://127.0.0.1:8765/mcp
  robocog-server --view                           # stdio, and the live viewer on http://127.0.0.1:8766/
  robocog-server --transport http --robots 32 --profile eval   # a fleet: a robot per HTTP session
  robocog-server --profile eval --data-dir /tmp/mem --memory-namespace trial-3
  robocog-server --memory-url http://127.0.0.1:8000   # share one Chroma server between robots

environment:
  ROBOCOG_DATA_DIR   default for --data-dir
  ROBOCOG_AUTH_TOKEN default for --auth-token
"""


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="robocog-server",
        allow_abbrev=False,  # a router passes arguments on to its fleet processes by their full names
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    t = p.add_argument_group("transport")
    t.add_argument("--transport", choices=["stdio", "http"], default="stdio", help="default: stdio")
    t.add_argument("--host", default="127.0.0.1", help="HTTP bind address (default: 127.0.0.1, this machine only)")
    t.add_argument("--port", type=int, default=8765, help="HTTP port (default: 8765); the endpoint is /mcp")
    t.add_argument("--log-level", default="WARNING", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    t.add_argument(
        "--view",
        nargs="?",
        type=_port,
        const=8766,
        default=None,
        metavar="PORT",
        help="also serve the live viewer (a web page: the map, the camera, the tool calls as they happen) on "
        "http://127.0.0.1:PORT/ (default port: 8766; 0 picks a free one), with any transport",
    )
    t.add_argument(
        "--no-app",
        action="store_true",
        help="publish no robot app (the MCP App ui://robocog/robot that hosts such as Claude Desktop show in the "
        "chat, the robot tools' links to it, and its robot_view tool)",
    )
    a = p.add_argument_group("access (HTTP: see the docs' Security page, docs/security.md)")
    a.add_argument(
        "--auth-token",
        default=os.environ.get("ROBOCOG_AUTH_TOKEN") or None,
        metavar="TOKEN",
        help="HTTP clients must send 'Authorization: Bearer TOKEN' (default: $ROBOCOG_AUTH_TOKEN; 'generate' "
        "makes one and prints it); required when --host is not loopback",
    )
    a.add_argument(
        "--allowed-host",
        action="append",
        default=[],
        metavar="HOST[:PORT]",
        help="a Host header to accept besides loopback and this machine's names (repeatable)",
    )
    a.add_argument(
        "--allowed-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="a browser Origin to accept besides loopback, e.g. https://robot.example (repeatable)",
    )
    a.add_argument(
        "--max-sessions",
        type=_positive(int),
        default=None,
        help=f"HTTP sessions open at once; past it a new one gets 503 (default: {DEFAULT_MAX_SESSIONS}, or --robots "
        "plus 4 for a larger fleet)",
    )
    a.add_argument(
        "--session-idle-s",
        type=_positive(float),
        default=DEFAULT_SESSION_IDLE_S,
        help=f"close an HTTP session after this many seconds without a request (default: {DEFAULT_SESSION_IDLE_S:g})",
    )
    a.add_argument(
        "--json-response",
        action="store_true",
        help="answer each HTTP call with one JSON body instead of an event stream: cheaper, but no progress or "
        "log notification reaches the caller during a call (a harness's fleets, which never ask for them)",
    )
    a.add_argument(
        "--confirm-actions",
        action="store_true",
        help="ask the user (MCP elicitation) before every move_to, grab and place: for desktop use",
    )
    a.add_argument(
        "--allow-tools",
        type=_tool_list,
        default=None,
        metavar="TOOL,...",
        help="publish only these robot tools, e.g. look_around,search_memory (default: all)",
    )
    w = p.add_argument_group("world")
    w.add_argument(
        "--profile",
        choices=["default", "eval"],
        default="default",
        help="'eval' adds reset_world, begin_task, check_task and clear_memory for evaluation harnesses",
    )
    w.add_argument(
        "--scene",
        type=Path,
        default=None,
        help="a scene YAML, or a shipped scene's name: household (the paper's, the default), suite_house, flat, "
        "kitchen_plus",
    )
    w.add_argument("--seed", type=int, default=None, help="seed of the world's random generator")
    w.add_argument("--randomize", action="store_true", help="start objects on seeded random free positions")
    w.add_argument(
        "--observe",
        choices=("location", "room", "house"),
        default="house",
        help="what look_around reveals: the robot's location, its room, or the whole house (the default; "
        "reset_world(observe=...) changes it per episode)",
    )
    w.add_argument(
        "--splits",
        type=Path,
        default=None,
        metavar="DIR",
        help="fresh splits generated from a seed (robocog eval writes them and passes this): "
        "reset_world(suite='SUITE@SEED') finds their instances in DIR/SUITE/SPLIT@SEED.jsonl",
    )
    w.add_argument("--gui", action="store_true", help="open the PyBullet GUI (needs a display)")
    w.add_argument(
        "--processes",
        type=_processes,
        default=1,
        metavar="P",
        help="spread the fleet's robots over P processes behind this one address ('auto': one per core), so "
        "it uses P cores (PyBullet holds the GIL: one process uses about one core); default: 1",
    )
    w.add_argument(
        "--robots",
        type=_positive(int),
        default=1,
        metavar="N",
        help="a fleet: each HTTP session (each driver) gets a robot of its own (its world, scratchpad and "
        "episode; memory is by namespace, shared), up to N at once, sharing one embedding model and one Chroma client; "
        "default: 1, one robot for every client (needs --transport http when above 1)",
    )
    m = p.add_argument_group("memory")
    m.add_argument(
        "--data-dir",
        type=Path,
        default=os.environ.get("ROBOCOG_DATA_DIR") or None,
        help="where the embedded episodic memory lives (default: $ROBOCOG_DATA_DIR or a per-user dir)",
    )
    m.add_argument("--memory-url", default=None, help="use a Chroma server at this URL instead, e.g. http://host:8000")
    m.add_argument("--memory-namespace", default="default", help="memory collection, so experiments never mix")
    m.add_argument(
        "--memory-labels",
        choices=["believed", "verified"],
        default="believed",
        help="what search_memory reports as a past episode's status (default: believed, as in the paper)",
    )
    m.add_argument(
        "--memory-namespaces",
        type=_positive(int),
        default=32,
        metavar="N",
        help="a fleet keeps at most N memory namespaces open (about 2.7 MB each); past it, it closes them all "
        "between calls and opens again those used next (default: 32)",
    )
    m.add_argument(
        "--search-k",
        type=_search_k,
        default=3,
        help="how many experiences search_memory returns when the model gives no k (1-20; default: 3; the paper: 5)",
    )
    return p


def _positive(kind: type[int] | type[float]) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{text!r} is not a positive number")
        return value

    return parse


def _whole(low: int, high: int | None, not_whole: str, out_of_range: str) -> Callable[[str], int]:
    """A parser of whole numbers from `low` to `high` (None: no bound); the messages are formats
    of the text given (`{text}`) and of the number (`{n}`)."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(not_whole.format(text=text)) from None
        if n < low or (high is not None and n > high):
            raise argparse.ArgumentTypeError(out_of_range.format(n=n))
        return n

    return parse


_port = _whole(0, 65535, "{text!r} is not a port number", "{n} is not a port number (0-65535)")
_search_k = _whole(1, 20, "{text!r} is not a whole number", "{n} is not between 1 and 20")
_count_of_processes = _whole(
    1, None, "{text!r} is not a number of processes (or 'auto')", "{n} is not a positive number of processes"
)


def _tool_list(text: str) -> frozenset[str]:
    names = frozenset(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError("name at least one tool")
    return names


def _processes(text: str) -> int:
    return (os.cpu_count() or 1) if text == "auto" else _count_of_processes(text)
