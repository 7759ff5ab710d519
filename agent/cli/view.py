"""`robocog view RESULTS`: browse a study in a web page on loopback (`robocog.agent.view`), or write it
as a static site (`--bundle DIR`)."""

from __future__ import annotations

import argparse
import socket
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    vw: argparse.ArgumentParser = sub.add_parser(
        "view", help="browse a study in a web page: tables, figures, attempts and their traces"
    )
    vw.add_argument("results", type=Path, help="results file written by robocog eval")
    vw.add_argument("--port", type=int, default=8767, help="port on 127.0.0.1 (default: 8767; 0 picks a free one)")
    vw.add_argument("--title", default=None, help="the report's title")
    vw.add_argument(
        "--bundle",
        type=Path,
        default=None,
        metavar="DIR",
        help="write the viewer as a static site into DIR (no server: open DIR/index.html, or publish DIR)",
    )
    return vw


def main(args: argparse.Namespace) -> int:
    return view_command(args)


def view_command(args: argparse.Namespace) -> int:
    """`robocog view RESULTS [--port P]`: serve the study until Ctrl-C (`robocog.agent.view.serve`);
    with `--bundle DIR`, write it as a static site instead (`robocog.agent.view.bundle`)."""
    if not args.results.is_file():
        print(f"robocog: {args.results}: no such results file", file=sys.stderr)
        return 2
    if args.bundle is not None:
        return bundle_command(args)
    import uvicorn

    from robocog.agent.view.serve import HOST, ResultsViewer  # Starlette and the report: only here

    try:
        viewer = ResultsViewer(args.results, title=args.title)
    except ValueError as exc:
        print(f"robocog: {args.results}: {exc}", file=sys.stderr)
        return 2
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((HOST, args.port))
        sock.listen(64)
        sock.setblocking(False)
        print(f"robocog: rendering the report of {len(viewer.rows)} attempts ...", file=sys.stderr, flush=True)
        viewer.prepare()
        config = uvicorn.Config(viewer.app(), log_level="warning", lifespan="off")
        url = f"http://{HOST}:{sock.getsockname()[1]}/"
        print(f"robocog: results viewer at {url} (Ctrl-C stops it)", file=sys.stderr, flush=True)
        uvicorn.Server(config).run(sockets=[sock])
    except OSError as exc:
        print(f"robocog: the results viewer cannot listen on {HOST}:{args.port}: {exc}", file=sys.stderr)
        return 2
    finally:
        sock.close()
        viewer.close()
    return 0


def bundle_command(args: argparse.Namespace) -> int:
    """`robocog view RESULTS --bundle DIR`: write the static bundle, say where and how big."""
    from pydantic import ValidationError

    from robocog.agent.view.bundle import write_bundle

    try:
        stats = write_bundle(args.results, args.bundle, title=args.title)
    except (ValueError, ValidationError, OSError) as exc:
        problem = " ".join(str(exc).split())
        print(
            f"robocog: {problem if problem.startswith(str(args.results)) else f'{args.results}: {problem}'}",
            file=sys.stderr,
        )
        return 2
    print(
        f"bundle: {stats.index} ({stats.files} files, {stats.bytes / 1e6:.1f} MB, {stats.traces} traces, "
        f"{stats.pictures} pictures, {stats.seconds:.1f} s); open it from disk or put the folder on any static host"
    )
    return 0
