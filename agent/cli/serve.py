"""`robocog serve [SERVER OPTIONS]`: start the MCP server, as `robocog-server` does (for hosts that run
one command from the package, such as the MCP Registry's `uvx robocog serve`). It replaces this
process with `robocog-server`, so the client never imports the server."""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p: argparse.ArgumentParser = sub.add_parser(
        "serve",
        help="start the MCP server (robocog-server) with the options that follow, e.g. robocog serve --transport http",
        add_help=False,
    )
    p.add_argument("server_args", nargs=argparse.REMAINDER, help="robocog-server's options (robocog serve --help)")
    return p


def main(args: argparse.Namespace) -> int:
    beside = Path(sys.executable).parent / "robocog-server"
    command = [str(beside)] if beside.exists() else [shutil.which("robocog-server") or ""]
    if not command[0]:
        command = [sys.executable, "-m", "robocog.server.cli"]
    sys.stdout.flush()
    os.execv(command[0], [*command, *args.server_args])
    return 0  # not reached: execv replaces the process
