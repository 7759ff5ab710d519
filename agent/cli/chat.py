"""`robocog chat`: type tasks one after another to the same robot."""

from __future__ import annotations

import argparse
import asyncio
from typing import Any

from robocog.agent.cli.options import EPILOG, add_connection, add_model, add_view, check_options
from robocog.agent.cli.run import preload_litellm, prepare, run_tasks


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p: argparse.ArgumentParser = sub.add_parser(
        "chat",
        help="type tasks one after another to the same robot",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_model(p)
    add_connection(p)
    add_view(p)
    return p


def main(args: argparse.Namespace) -> int:
    check_options(args)
    prepare(args)
    loader = preload_litellm(args.model)
    print("Type a task (or a task id such as T1); an empty line, /quit or Ctrl-D ends the session.")
    return asyncio.run(run_tasks(args, None, loader))
