"""`robocog-server`: the household robot as an MCP server (stdio by default, or streamable HTTP)."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from robocog.server.config import DEFAULT_MAX_SESSIONS, DEFAULT_SESSION_IDLE_S

if TYPE_CHECKING:
    from robocog.server.http import HttpOptions

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
    p = argparse.ArgumentParser(
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
    a = p.add_argument_group("access (HTTP: see the README's 'Security' section)")
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
        help="a scene YAML, or a shipped scene's name: household (the paper's, the default), suite_house, flat",
    )
    w.add_argument("--seed", type=int, default=None, help="seed of the world's random generator")
    w.add_argument("--randomize", action="store_true", help="start objects on seeded random free positions")
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


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{port} is not a port number (0-65535)")
    return port


def _tool_list(text: str) -> frozenset[str]:
    names = frozenset(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError("name at least one tool")
    return names


def _processes(text: str) -> int:
    if text == "auto":
        return os.cpu_count() or 1
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of processes (or 'auto')") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{n} is not a positive number of processes")
    return n


def _port_taken(host: str, port: int) -> str | None:
    """Why `host:port` cannot be listened on (in use, or not this machine's), or None (port 0: free)."""
    import socket

    if not port:
        return None
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as exc:
            return f"cannot listen on {host}:{port}: {exc.strerror or exc}; give another port"
    return None


def _search_k(text: str) -> int:
    try:
        k = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if not 1 <= k <= 20:
        raise argparse.ArgumentTypeError(f"{k} is not between 1 and 20")
    return k


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from robocog.shared.process import follow_parent

    follow_parent()  # a fleet process of a router or a harness ends with it
    from robocog.server.config import AccessConfig
    from robocog.server.http import HttpOptions, generate_token, is_loopback, machine_names, serve
    from robocog.shared.errors import ConfigError

    if args.max_sessions is not None and args.max_sessions < args.robots:
        print(
            f"robocog-server: --max-sessions {args.max_sessions} is below --robots {args.robots}: some robots "
            "could never be driven (a robot is a session's)",
            file=sys.stderr,
        )
        return 2
    if args.robots > 1 and args.transport != "http":
        print("robocog-server: --robots above 1 needs --transport http (stdio has one client)", file=sys.stderr)
        return 2
    if args.robots > 1 and args.view is not None:
        print("robocog-server: --view watches one robot: it cannot be combined with --robots above 1", file=sys.stderr)
        return 2
    if args.robots > 1 and args.gui:
        print("robocog-server: --gui shows one robot: it cannot be combined with --robots above 1", file=sys.stderr)
        return 2
    if args.processes > args.robots:
        print(
            f"robocog-server: --processes {args.processes} is more than --robots {args.robots}: each process "
            "hosts some of the robots",
            file=sys.stderr,
        )
        return 2
    token = generate_token() if args.auth_token == "generate" else args.auth_token
    http = HttpOptions(
        host=args.host,
        port=args.port,
        auth_token=token,
        allowed_hosts=tuple(args.allowed_host),
        allowed_origins=tuple(args.allowed_origin),
        max_sessions=int(args.max_sessions or max(DEFAULT_MAX_SESSIONS, args.robots + 4)),
        session_idle_s=args.session_idle_s,
        machine_names=() if args.transport == "stdio" or is_loopback(args.host) else machine_names(),
    )
    access = AccessConfig(
        auth_token=token if args.transport == "http" else None,
        url=http.url,
        confirm_actions=args.confirm_actions,
        allow_tools=args.allow_tools,
        lease_idle_s=args.session_idle_s,
    )
    if args.transport == "http":
        try:
            http.check()
        except ConfigError as exc:
            print(f"robocog-server: {exc}", file=sys.stderr)
            return 2
    for flag, host, port in (
        ("--port", args.host, args.port if args.transport == "http" else 0),
        ("--view", "127.0.0.1", args.view or 0),
    ):
        taken = _port_taken(host, port)
        if taken:  # one line now, before any banner says where the server is
            print(f"robocog-server: {flag} {port}: {taken}", file=sys.stderr)
            return 2
    from robocog.shared.errors import WorldError
    from robocog.shared.memory_names import collection_name, parse_chroma_url
    from robocog.shared.scene_files import load_scene, scene_path

    # Fail fast, with the reason on one line, before any client connects (and before PyBullet
    # announces itself on stderr): the scene and every file it names, the memory's address.
    try:
        if args.scene is not None:
            args.scene = scene_path(args.scene)  # a shipped scene's name, or a path
            load_scene(args.scene)
        if args.memory_url is not None:
            parse_chroma_url(args.memory_url)
            if args.data_dir is not None:
                from_env = os.environ.get("ROBOCOG_DATA_DIR")
                if from_env and args.data_dir == Path(from_env):
                    args.data_dir = None  # $ROBOCOG_DATA_DIR is only a default: --memory-url overrides it
                else:
                    raise ConfigError(
                        "--data-dir and --memory-url cannot be used together: --data-dir is where embedded "
                        "memory lives, --memory-url a Chroma server's; give one"
                    )
        collection_name(args.memory_namespace)
    except (ConfigError, ValueError) as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2

    if args.processes > 1:  # a router in front of fleet processes: no robot in this process
        return _route(args, list(argv) if argv is not None else sys.argv[1:], http)

    from robocog.server.world.cstdio import c_output_discarded

    with c_output_discarded(stderr=True):
        import pybullet  # noqa: F401

    from robocog.server.app import build_server
    from robocog.server.session import SessionConfig

    if args.gui and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        print("robocog-server: --gui needs a display and none is set (DISPLAY is empty)", file=sys.stderr)
        return 2
    config = SessionConfig(
        scene=args.scene,
        seed=args.seed,
        randomize=args.randomize,
        gui=args.gui,
        data_dir=args.data_dir,
        memory_url=args.memory_url,
        namespace=args.memory_namespace,
        memory_labels=args.memory_labels,
        search_k=args.search_k,
    )
    try:
        server = build_server(
            config,
            profile=args.profile,
            log_level=args.log_level,
            access=access,
            view=args.view,
            robots=int(args.robots),
            per_driver=True if os.environ.get("ROBOCOG_FLEET_PROCESS") else None,
            open_namespaces=args.memory_namespaces,
        )
    except ConfigError as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2
    try:
        if args.transport == "stdio":
            server.run("stdio")
        else:
            routed = os.environ.get("ROBOCOG_FLEET_PROCESS")  # a process of a fleet behind a router
            where = f"fleet process {routed} ready" if routed else f"MCP over streamable HTTP at {http.url}"
            print(f"robocog-server: {where}", file=sys.stderr)
            if args.auth_token == "generate":
                print(f"robocog-server: bearer token (clients send it as ROBOCOG_AUTH_TOKEN): {token}", file=sys.stderr)
            serve(server, http, log_level=args.log_level)
    except WorldError as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        pass
    return 0


def _route(args: argparse.Namespace, argv: list[str], http: HttpOptions) -> int:
    """Serve the fleet's P processes behind the public address (`robocog.server.router`)."""
    from robocog.server.router import Fleet, serve
    from robocog.shared.errors import ConfigError

    fleet = Fleet(
        argv,
        robots=args.robots,
        processes=args.processes,
        allowed_hosts=http.host_names(),
        auth_token=http.auth_token,
        data_dir=args.data_dir,
        memory_url=args.memory_url,
        session_idle_s=args.session_idle_s,
    )
    try:
        with fleet as router:
            print(
                f"robocog-server: MCP over streamable HTTP at {http.url}: {args.robots} robots in "
                f"{args.processes} processes",
                file=sys.stderr,
            )
            if args.auth_token == "generate":
                print(
                    f"robocog-server: bearer token (clients send it as ROBOCOG_AUTH_TOKEN): {http.auth_token}",
                    file=sys.stderr,
                )
            serve(router, args.host, args.port, args.log_level)
    except ConfigError as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        pass
    return 0


def run() -> None:
    """Console-script entry point: once the server has shut down cleanly (the lifespan closed the
    world and the memory), leave at once instead of waiting for the interpreter to tear down
    ChromaDB's and onnxruntime's threads (about 0.4 s that a client would spend waiting)."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main())
