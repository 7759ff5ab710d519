"""`robocog contract dump | check BASELINE.json`: the published MCP contract of any server
(`robocog.agent.contract`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def add_parser(commands: Any) -> argparse.ArgumentParser:
    """`robocog contract dump | check BASELINE.json`, with the server options."""
    parser: argparse.ArgumentParser = commands.add_parser(
        "contract", help="dump a server's MCP contract, or check it against a baseline (any MCP server)"
    )
    sub = parser.add_subparsers(dest="contract_command", required=True)
    dump = sub.add_parser("dump", help="print the live server's canonical contract (JSON)")
    check = sub.add_parser(
        "check",
        help="compare the live server with a baseline contract: exit 0 compatible, 1 breaking, 2 unreachable",
    )
    check.add_argument("baseline", type=Path, help="a contract file, e.g. assets/contract/default.json")
    check.add_argument(
        "--exercise",
        action="store_true",
        help="also call each read-only tool that needs no arguments and validate its result against its outputSchema",
    )
    check.add_argument("--quiet", action="store_true", help="print only the breaking changes and the summary")
    for p in (dump, check):
        g = p.add_argument_group("server (any MCP server; default: a spawned robocog-server)")
        g.add_argument("--url", help="a running server over streamable HTTP, e.g. http://127.0.0.1:8765/mcp")
        g.add_argument("--server-cmd", help="command line that starts the server over stdio")
        g.add_argument(
            "--profile",
            choices=("default", "eval"),
            default=None,
            help="profile of the spawned robocog-server (default: default; for check, the baseline's file name "
            "when it is eval.json)",
        )
        g.add_argument("--data-dir", help="memory directory of the spawned robocog-server (default: a temporary one)")
    return parser


def main(args: argparse.Namespace) -> int:
    from robocog.agent.contract.check import contract_command  # the MCP SDK: only for this command

    return contract_command(args)
