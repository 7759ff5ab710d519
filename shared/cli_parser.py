"""The command-line parser both commands use: a usage error is one line, without the usage block.

argparse prints the whole usage (fifteen lines for `robocog-server`) before its error; a person who
typed one wrong value reads past all of it to find the line that matters. Here the error is that one
line, and where to see the usage: `robocog-server: error: argument --observe: invalid choice: 'bogus'
(choose from 'location', 'room', 'house'); see robocog-server --help`. Subcommands' parsers are made
of the same class (argparse's `add_subparsers` uses the parent's), so `robocog run` says the same.
"""

from __future__ import annotations

import argparse
import sys
from typing import NoReturn


class OneLineParser(argparse.ArgumentParser):
    """An `ArgumentParser` whose usage errors are one line on stderr (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}; see {self.prog} --help\n")

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        if message:
            sys.stderr.write(message)
        sys.exit(status)
