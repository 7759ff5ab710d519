"""`robocog-server`: the household robot as an MCP server (stdio by default, or streamable HTTP)."""

from __future__ import annotations

import argparse
import gc
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from robocog.server.cli_options import build_parser
from robocog.server.config import DEFAULT_MAX_SESSIONS, event_loop_options

if TYPE_CHECKING:
    from robocog.server.transport.http import HttpOptions


def _port_taken(host: str, port: int) -> str | None:
    """Why `host:port` cannot be listened on (in use, or not this machine's), or None (port 0: free)."""
    from robocog.shared.process import probe_bind

    why = probe_bind(host, port)[1] if port else None
    return f"cannot listen on {host}:{port}: {why}; give another port" if why else None


def main(argv: Sequence[str] | None = None) -> int:
    from robocog.shared.process import follow_parent, limit_malloc_arenas

    limit_malloc_arenas()  # before any thread: a long-lived server's memory stays flat
    args = build_parser().parse_args(argv)
    follow_parent()  # a fleet process of a router or a harness ends with it
    from robocog.server.config import AccessConfig
    from robocog.server.transport.http import HttpOptions, generate_token, is_loopback, machine_names, serve
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
        json_response=args.json_response,
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
    taken = _port_taken(args.host, args.port if args.transport == "http" else 0)
    if taken:  # one line now, before any banner says where the server is
        print(f"robocog-server: --port {args.port}: {taken}", file=sys.stderr)
        return 2
    from robocog.shared.process import probe_bind

    why = probe_bind("127.0.0.1", args.view)[1] if args.view else None
    if why:  # the viewer is optional: it never takes the MCP server down
        print(
            f"robocog-server: the live viewer's port {args.view} is in use or cannot be listened on ({why}); the "
            "viewer serves on a free port instead (its address follows), and the MCP server runs as asked",
            file=sys.stderr,
        )
        args.view = 0
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
    from robocog.server.robots.session import SessionConfig

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
        observe=args.observe,
        splits=args.splits,
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
            app=not args.no_app,
        )
    except ConfigError as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2
    # What is made by now (the imports, the app, its first robot) lives as long as the process: out of
    # the collector's sight, its full collections no longer walk it (a fleet's took 0.1 s each).
    gc.freeze()
    try:
        if args.transport == "stdio":
            import anyio

            from robocog.server.transport.stdio import serve_stdio

            anyio.run(serve_stdio, server, backend_options=event_loop_options())
        else:
            routed = os.environ.get("ROBOCOG_FLEET_PROCESS")  # a process of a fleet behind a router
            where = f"fleet process {routed} ready" if routed else f"MCP over streamable HTTP at {http.url}"
            print(f"robocog-server: {where}", file=sys.stderr)
            _say_generated_token(args, http)
            serve(server, http, log_level=args.log_level)
    except WorldError as exc:
        print(f"robocog-server: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        pass
    return 0


def _say_generated_token(args: argparse.Namespace, http: HttpOptions) -> None:
    """With `--auth-token generate`, the token this server made up, for its clients."""
    if args.auth_token == "generate":
        token = http.auth_token
        print(f"robocog-server: bearer token (clients send it as ROBOCOG_AUTH_TOKEN): {token}", file=sys.stderr)


def _route(args: argparse.Namespace, argv: list[str], http: HttpOptions) -> int:
    """Serve the fleet's P processes behind the public address (`robocog.server.routing.router`)."""
    from robocog.server.routing.router_processes import Fleet, serve
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
            _say_generated_token(args, http)
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
