"""`robocog scene generate | list`: a generated house written byte-identically for its seed, and the
scenes robocog ships (the hand-made ones and the generated houses)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from robocog.shared.errors import ConfigError

#: The largest seed `generate` takes (a seed is a name's number: house-NNN).
MAX_SEED = 2**31 - 1


def add_parser(commands: Any) -> argparse.ArgumentParser:
    """`robocog scene` and its subcommands."""
    parser: argparse.ArgumentParser = commands.add_parser(
        "scene", help="scenes: generate a house from a seed, list the shipped scenes"
    )
    sub = parser.add_subparsers(dest="scene_command", required=True)
    gen = sub.add_parser("generate", help="generate a house (byte-identical scene YAML for the same seed)")
    gen.add_argument("--seed", type=int, required=True, help="the house's seed (0 to 49 are the shipped houses)")
    gen.add_argument("--name", default=None, help="the scene's name (default: house-NNN for seed NNN)")
    gen.add_argument("-o", "--out", type=Path, default=None, help="write the YAML here (default: stdout)")
    sub.add_parser("list", help="the shipped scenes and generated houses, with their rooms and objects")
    return parser


def main(args: argparse.Namespace) -> int:
    """`robocog scene generate | list`."""
    from robocog.agent.housegen import house_yaml
    from robocog.shared.scene_files import generated_scene_names, load_scene, scene_names, scene_path

    if args.scene_command == "generate":
        if not 0 <= args.seed <= MAX_SEED:
            raise ConfigError(f"--seed: must be between 0 and {MAX_SEED}, not {args.seed}")
        if args.name is not None and not args.name.strip():
            raise ConfigError("--name: must not be empty")
        text = house_yaml(args.seed, args.name)
        if args.out is None:
            sys.stdout.write(text)
        else:
            try:
                args.out.write_bytes(text.encode("utf-8"))
            except OSError as exc:
                raise ConfigError(f"--out: cannot write {args.out}: {exc.strerror or exc}") from None
            print(f"robocog: house {args.seed} -> {args.out}", file=sys.stderr)
        return 0
    rows = [("scene", "rooms", "locations", "positions", "objects")]
    for name in [*scene_names(), *generated_scene_names()]:
        scene = load_scene(scene_path(name))
        rows.append(
            (
                name,
                str(len(scene.rooms)),
                str(len(scene.locations)),
                str(len(scene.place_positions)),
                ", ".join(o.name for o in scene.objects),
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    print("\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows))
    return 0
