"""`robocog`: drive the robot with any model through LiteLLM (`run`, `chat`), evaluate, report.

Every command is a module of this package with `add_parser(subparsers)` and `main(args) -> int`,
listed once in `COMMANDS`. A command module imports only what its parser needs at the top; what the
command runs (the MCP SDK, LiteLLM, PyBullet's client, Starlette) it imports in its `main`, so
`robocog --help` and `robocog report` start without them.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from robocog.agent.cli.options import EPILOG
from robocog.agent.suitegen import generate_on_demand
from robocog.shared.cli_parser import OneLineParser
from robocog.shared.errors import ConfigError, ServerConnectionError

#: The commands, in the order `robocog --help` lists them: name -> module (robocog.agent.cli.NAME).
COMMANDS: dict[str, str] = {
    "run": "run",
    "chat": "chat",
    "eval": "eval",
    "bench": "bench",
    "report": "report",
    "view": "view",
    "leaderboard": "leaderboard",
    "submit": "submit",
    "suite": "suite",
    "scene": "scene",
    "contract": "contract",
    "serve": "serve",
}


def command_module(name: str) -> ModuleType:
    """The module of the command `name`."""
    return importlib.import_module(f"robocog.agent.cli.{COMMANDS[name]}")


def command_module_named(module: str) -> ModuleType:
    """The module robocog.agent.cli.`module`."""
    return importlib.import_module(f"robocog.agent.cli.{module}")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="robocog",
        description="Drive the robocog household robot with any model, over MCP.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        command_module(name).add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    given = list(sys.argv[1:] if argv is None else argv)
    if given[:1] == ["serve"]:  # every option after it is the server's own (argparse would claim --help)
        return int(command_module("serve").main(argparse.Namespace(server_args=given[1:])))
    args = build_parser().parse_args(given)
    generate_on_demand()  # fresh splits, generated when a command first needs one
    try:
        # a subcommand may be run by a module of its own (`robocog submit verify`: it runs a server)
        code: int = command_module_named(getattr(args, "command_module", None) or COMMANDS[args.command]).main(args)
        return code
    except KeyboardInterrupt:
        return 130
    except (ConfigError, ServerConnectionError) as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    except (OSError, BaseExceptionGroup) as exc:
        from robocog.agent.client.connection import leaf_message

        leaf = exc
        while isinstance(leaf, BaseExceptionGroup) and leaf.exceptions:
            leaf = leaf.exceptions[0]
        if isinstance(leaf, ConfigError | ServerConnectionError):  # it says what happened itself
            print(f"robocog: {leaf}", file=sys.stderr)
        else:
            print(f"robocog: cannot reach the robot server: {leaf_message(exc)}", file=sys.stderr)
        return 2


def run() -> None:
    """Console-script entry point: exit as soon as the work is done and written (traces and results
    are closed by then), instead of waiting for LiteLLM's logging worker to wind down (about 2 s)."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    run()
