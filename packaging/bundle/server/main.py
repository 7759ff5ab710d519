"""The MCP Bundle's entry point: turns the host's user settings into robocog-server options.

A host (Claude Desktop and others) runs this file as the bundle's manifest.json says, with `uv run`
in the unpacked bundle, and substitutes the user's settings into the arguments, each one word:

    main.py --data-dir=DIR --scene=SCENE --view=PORT --confirm=true|false

Each setting reaches robocog-server as one word too (`--view=PORT`), so no value, whatever it
holds, becomes an option of its own; and each is checked first: a port is a whole number from 0 to
65535, the memory directory is not a file, "confirm" is true or false. A bad value ends the start
with one line that names the setting as the extension's settings show it (its title in
manifest.json). An empty setting (or one the host left as its `${user_config...}` placeholder) keeps
the server's default. `--confirm=true` is the server's flag `--confirm-actions`, and the server is
told the setting's title (`ROBOCOG_CONFIRM_SETTING`), so that a client which cannot ask its user is
told to turn that setting off. Every other argument goes to robocog-server unchanged.
"""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path

MANIFEST = Path(__file__).resolve().parent.parent / "manifest.json"

#: The bundle's options: (its setting in manifest.json's user_config, robocog-server's option).
SETTINGS = {
    "--data-dir": ("memory_dir", "--data-dir"),
    "--scene": ("scene", "--scene"),
    "--view": ("viewer_port", "--view"),
    "--confirm": ("confirm_actions", "--confirm-actions"),
}
#: What robocog-server reads as the title of the "confirm" setting (robocog.server.robots.consent).
CONFIRM_SETTING_ENV = "ROBOCOG_CONFIRM_SETTING"


class SettingError(ValueError):
    """A setting's value that robocog-server must not be given; its message names the setting."""


def titles() -> dict[str, str]:
    """Each setting's title as the extension's settings show it (its key where manifest.json is absent)."""
    try:
        config = json.loads(MANIFEST.read_text(encoding="utf-8"))["user_config"]
    except (OSError, ValueError, KeyError):
        return {}
    return {key: str(entry.get("title") or key) for key, entry in config.items()}


def is_unset(value: str) -> bool:
    """True when a host passed no value: an empty string, or its placeholder left as it was."""
    return not value.strip() or value.startswith("${")


def port(value: str) -> str:
    """A port number's text ("8766"; a host may write a number as "8766.0"), else `ValueError`."""
    found = re.fullmatch(r"\s*(\d{1,5})(?:\.0*)?\s*", value)
    if found is None or int(found.group(1)) > 65535:
        raise ValueError("not a port number (a whole number from 0 to 65535)")
    return str(int(found.group(1)))


def directory(value: str) -> str:
    """A directory's path (made when missing, by the server), else `ValueError`."""
    if Path(value).expanduser().exists() and not Path(value).expanduser().is_dir():
        raise ValueError("a file, not a directory")
    return value


def yes_or_no(value: str) -> bool:
    """A boolean setting as a host writes it ("true", "false"), else `ValueError`."""
    word = value.strip().lower()
    if word in ("true", "1", "yes"):
        return True
    if word in ("false", "0", "no"):
        return False
    raise ValueError("neither true nor false")


#: Each value setting's check (a scene, a shipped name or a YAML path, robocog-server checks itself).
CHECKS = {"--data-dir": directory, "--scene": str, "--view": port}


def server_argv(argv: Sequence[str]) -> list[str]:
    """robocog-server's arguments for the bundle's arguments (see the module's docstring); raises
    `SettingError` for a value the server must not be given."""
    named = titles()
    out: list[str] = []
    for arg in argv:
        option, equals, value = arg.partition("=")
        if option not in SETTINGS or not equals:
            out.append(arg)
            continue
        key, server_option = SETTINGS[option]
        if is_unset(value):
            continue
        try:
            if option == "--confirm":
                if yes_or_no(value):
                    out.append(server_option)
                continue
            out.append(f"{server_option}={CHECKS[option](value)}")
        except ValueError as exc:
            raise SettingError(f"the setting '{named.get(key, key)}' is {value!r}: {exc}") from None
    return out


def main() -> None:
    """Start robocog-server over stdio with the host's settings."""
    try:
        argv = server_argv(sys.argv[1:])
    except SettingError as exc:
        print(f"robocog extension: {exc}; change it in the extension's settings", file=sys.stderr)
        raise SystemExit(2) from None
    if "--confirm-actions" in argv:
        os.environ[CONFIRM_SETTING_ENV] = titles().get("confirm_actions", "confirm_actions")
    from robocog.server import cli

    sys.argv = ["robocog-server", *argv]
    cli.run()


if __name__ == "__main__":
    main()
