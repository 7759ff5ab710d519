"""`robocog chat`: type tasks one after another to the same robot."""

from __future__ import annotations

import argparse
from typing import Any

from robocog.agent.cli.run import add_session_parser, start


def add_parser(sub: Any) -> argparse.ArgumentParser:
    return add_session_parser(sub, "chat", "type tasks one after another to the same robot")


def main(args: argparse.Namespace) -> int:
    return start(args, None)
