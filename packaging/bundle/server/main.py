"""The MCP Bundle's entry point: turns the host's user settings into robocog-server options.

A host (Claude Desktop and others) runs this file as the bundle's manifest.json says, with `uv run`
in the unpacked bundle, and substitutes the user's settings into the arguments:

    main.py --data-dir DIR --scene SCENE --view PORT --confirm true|false

An empty setting (or one the host left as its `${user_config...}` placeholder) keeps the server's
default. `--confirm` is a boolean setting, which a host writes as "true" or "false"; the server
takes it as the flag `--confirm-actions`. Every other argument goes to robocog-server unchanged.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

# The bundle's settings that take a value: (our option, robocog-server's option).
VALUE_SETTINGS = {"--data-dir": "--data-dir", "--scene": "--scene", "--view": "--view"}


def is_unset(value: str) -> bool:
    """True when a host passed no value: an empty string, or its placeholder left as it was."""
    return not value.strip() or value.startswith("${")


def server_argv(argv: Sequence[str]) -> list[str]:
    """robocog-server's arguments for the bundle's arguments (see the module's docstring)."""
    out: list[str] = []
    args = list(argv)
    i = 0
    while i < len(args):
        arg = args[i]
        if arg in VALUE_SETTINGS or arg == "--confirm":
            value = args[i + 1] if i + 1 < len(args) else ""
            i += 2
            if is_unset(value):
                continue
            if arg == "--confirm":
                if value.strip().lower() in ("true", "1", "yes"):
                    out.append("--confirm-actions")
            else:
                out += [VALUE_SETTINGS[arg], value]
            continue
        out.append(arg)
        i += 1
    return out


def main() -> None:
    """Start robocog-server over stdio with the host's settings."""
    from robocog.server import cli

    sys.argv = ["robocog-server", *server_argv(sys.argv[1:])]
    cli.run()


if __name__ == "__main__":
    main()
