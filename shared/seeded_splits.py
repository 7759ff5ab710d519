"""Fresh splits: a suite's split generated on demand from a seed no model has seen, spelled
`SPLIT@SEED` ("test@12345") wherever a split is named (a study's `split`, `robocog eval --split`, a
submission's `split`, the leaderboard's split column).

A seeded split is what `robocog suite generate --split SPLIT --seed SEED` writes (the manifest's
size per family), byte-identical for the same seed. It is generated once into a cache
(`cache_home()`: `$ROBOCOG_SPLITS_CACHE`, else `$XDG_CACHE_HOME/robocog/splits`, else
`~/.cache/robocog/splits`) under a root keyed by the generator's digest (`root_for`: robocog's
version, the generator's source, the suite's files and the scenes), as `ROOT/SUITE/SPLIT@SEED.jsonl`
beside a copy of the suite's manifest. The generator lives on the client (`robocog.agent.suitegen`):
its commands hand it to this module (`use_generator`); the server never generates, it reads the
root it is given (`robocog-server --splits ROOT`), where `reset_world(suite="SUITE@SEED", ...)`
finds the instance (`robocog.shared.suite.find_seeded_instance`; `load_split` reads a fresh split
from the cache, generating it first when it is missing).

A seed is a decimal integer from 0 to `MAX_SEED`; a manifest asking more than `MAX_PER_FAMILY`
instances per family is not generated on demand. Every refusal is a `ConfigError` of one line.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Callable
from functools import cache
from pathlib import Path

from robocog.shared.errors import ConfigError

#: The largest seed a fresh split takes (the generator's seeds are 31-bit).
MAX_SEED = 2**31 - 1
#: Instances per family a split generated on demand may have (robocog-v2.1's test split has 60).
MAX_PER_FAMILY = 100
_SEEDED = re.compile(r"([A-Za-z0-9_\-]{1,64})@([0-9]{1,10})")
#: A fresh split's suite as reset_world names it: "robocog-v2.1@12345".
SUITE_AT = re.compile(r"([A-Za-z0-9_\-]+(?:\.[A-Za-z0-9_\-]+)*)@([0-9]{1,10})")

#: Writes a seeded split into the cache: (suite name or directory, split, seed, root) -> the file.
Generator = Callable[[str, str, int, Path], Path]
_generator: list[Generator] = []


def use_generator(generate: Generator) -> None:
    """Let `load_split` generate a fresh split missing from the cache (the client's commands call this)."""
    _generator[:] = [generate]


def parse_split(text: object) -> tuple[str, int | None]:
    """A split's name and its seed (None: the split the suite ships); a `ConfigError` refuses a seed
    that is not a decimal integer from 0 to `MAX_SEED`, in one line."""
    if not isinstance(text, str):
        raise ConfigError(f"split {str(text)[:80]!r} is not a split's name")
    if "@" not in text:
        return text, None
    match = _SEEDED.fullmatch(text)
    if match is None or int(match[2]) > MAX_SEED:
        raise ConfigError(
            f"split {text[:80]!r}: a fresh split is SPLIT@SEED, SEED a decimal integer from 0 to {MAX_SEED}"
        )
    return match[1], int(match[2])


def split_text(split: str, seed: int | None) -> str:
    """A split as it is spelled: "test", or "test@12345" for one generated from a seed."""
    return split if seed is None else f"{split}@{seed}"


def cache_home() -> Path:
    """Where fresh splits are generated (see the module's docstring)."""
    explicit = os.environ.get("ROBOCOG_SPLITS_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "robocog" / "splits"


def _files(directory: Path, patterns: tuple[str, ...]) -> list[Path]:
    return sorted(p for pattern in patterns for p in directory.glob(pattern) if p.is_file())


@cache
def _code_digest() -> str:
    """robocog's version and the source of what generates and reads instances (read as files)."""
    from robocog.assets import ASSETS_DIR
    from robocog.shared import __version__

    package = Path(__file__).resolve().parent.parent  # shared/ and agent/ side by side
    digest = hashlib.sha256(__version__.encode())
    parts: list[tuple[Path, tuple[str, ...]]] = [(package / "shared", ("*.py",))]
    parts += [(package / "agent" / p, ("*.py", "*.yaml")) for p in ("suitegen", "families", "symbolic")]
    parts += [(ASSETS_DIR / "families", ("*.yaml",)), (ASSETS_DIR / "scenes", ("*.yaml", "generated/*.yaml"))]
    for directory, patterns in parts:
        for path in _files(directory, patterns):
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def root_for(suite_directory: Path) -> Path:
    """The cache root of the suite in `suite_directory` under the current generator (its digest)."""
    digest = hashlib.sha256(_code_digest().encode())
    for path in _files(suite_directory, ("suite.yaml", "*/*.yaml")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return cache_home() / digest.hexdigest()[:20]


def split_file(root: Path, suite_name: str, split: str, seed: int) -> Path:
    return root / suite_name / f"{split}@{seed}.jsonl"


def check_generable(per_family: int, where: str) -> None:
    """Refuse a manifest asking more than `MAX_PER_FAMILY` instances per family of a fresh split."""
    if per_family > MAX_PER_FAMILY:
        raise ConfigError(
            f"{where}: {per_family} instances per family; a fresh split generates at most {MAX_PER_FAMILY}"
        )


def generate_missing(suite: str, split: str, seed: int, root: Path) -> None:
    """Generate `split@seed` of `suite` into `root` with the generator at hand (`use_generator`)."""
    if not _generator:
        raise ConfigError(f"split {split}@{seed} of {suite} is not generated (robocog eval generates it)")
    _generator[0](suite, split, seed, root)
