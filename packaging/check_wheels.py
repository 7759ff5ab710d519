"""Check that the staged MCP Bundle installs from wheels alone on every platform its manifest claims
(`make bundle-check`, so CI): for each platform in manifest.json's `compatibility.platforms` (uv's
targets for it: `build_bundle.PLATFORMS`) and each Python the bundle's project lets uv pick (its
`requires-python`, among the CPython releases uv can install), the bundle's lock, exported, is
resolved again with `uv pip compile --only-binary :all:`. Prints the matrix; exits 1 on a hole.

Usage: python packaging/check_wheels.py [--stage build/bundle] [--pythons 3.11,3.12,...]

`--pythons` resolves for those versions too, whether the project allows them or not (a table for
the docs); only a hole in a cell the project allows fails the check. Needs the package index.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

from packaging.specifiers import SpecifierSet
from packaging.version import Version

sys.path.insert(0, str(Path(__file__).resolve().parent))
from build_bundle import PLATFORMS, ROOT, Target, uv_command


def installable_pythons(uv: str) -> list[str]:
    """The CPython minor versions ("3.11") uv can install, final releases only, oldest first."""
    found = subprocess.run(
        [uv, "python", "list", "--all-versions", "--only-downloads", "--output-format", "json"],
        capture_output=True,
        text=True,
        check=True,
    )
    minors = {
        f"{v.major}.{v.minor}"
        for entry in json.loads(found.stdout)
        if entry.get("implementation") == "cpython" and not (v := Version(entry["version"])).is_prerelease
    }
    return sorted(minors, key=Version)


def allowed(requires_python: str, minor: str) -> bool:
    """Whether `requires-python` lets uv pick a Python of this minor version (its first release)."""
    return SpecifierSet(requires_python).contains(f"{minor}.0")


def export_lock(uv: str, stage: Path, out: Path) -> None:
    """The bundle's uv.lock as pinned requirements with their markers (robocog as the bundle's wheel)."""
    flags = ["--frozen", "--no-hashes", "--no-header", "--no-emit-project", "--quiet"]
    subprocess.run([uv, "export", "--project", str(stage), *flags, "--output-file", str(out)], check=True)


def resolves(uv: str, stage: Path, requirements: Path, target: Target, python: str) -> str | None:
    """None when the pinned requirements resolve from wheels alone for `target` and `python`, else
    uv's reason (its first line that says why)."""
    where = ["--python-platform", target.triple, "--python-version", python]
    # A file of its own, not os.devnull: uv reads an existing output file back for its pins, and a
    # newer uv fails on /dev/null ("Couldn't parse requirement in `/dev/null` at position 0").
    resolved = requirements.with_name(f"resolved-{target.triple}-{python}.txt")
    quiet = ["--no-header", "--no-annotate", "--quiet", "--output-file", str(resolved)]
    done = subprocess.run(
        [uv, "pip", "compile", str(requirements), "--only-binary", ":all:", *where, *quiet],
        cwd=stage,
        env={**os.environ, **dict(target.env)},
        capture_output=True,
        text=True,
    )
    if done.returncode == 0:
        return None
    lines = [line.strip() for line in done.stderr.splitlines() if line.strip()]
    return next((line for line in lines if "because" in line.lower()), lines[0] if lines else "uv failed")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=Path, default=ROOT / "build" / "bundle")
    parser.add_argument("--pythons", default="", help="also these minor versions, comma-separated")
    args = parser.parse_args()
    uv = uv_command()
    manifest = json.loads((args.stage / "manifest.json").read_text(encoding="utf-8"))
    with open(args.stage / "pyproject.toml", "rb") as f:
        requires = str(tomllib.load(f)["project"]["requires-python"])
    pythons = [p for p in installable_pythons(uv) if allowed(requires, p)]
    if not pythons:
        print(f"check_wheels: requires-python {requires} allows no Python uv can install", file=sys.stderr)
        return 1
    extra = [p.strip() for p in args.pythons.split(",") if p.strip() and p.strip() not in pythons]
    columns = sorted(pythons + extra, key=Version)
    holes: list[str] = []
    with tempfile.TemporaryDirectory() as scratch:
        requirements = Path(scratch) / "requirements.txt"
        export_lock(uv, args.stage, requirements)
        print(f"wheels only, the bundle's lock (requires-python {requires}):")
        print(f"  {'platform':10} {'target':26} " + " ".join(f"{p:>9}" for p in columns))
        for platform in manifest["compatibility"]["platforms"]:
            for target in PLATFORMS[platform]:
                cells = []
                for python in columns:
                    why = resolves(uv, args.stage, requirements, target, python)
                    cells.append("resolves" if why is None else "no")
                    if why is not None and python in pythons:
                        holes.append(f"{target.triple}, Python {python}: {why}")
                env = " ".join(f"{k}={v}" for k, v in target.env)
                print(f"  {platform:10} {target.triple:26} " + " ".join(f"{c:>9}" for c in cells) + f"  {env}")
    if extra:
        print(f"  (Python {', '.join(extra)}: not allowed by requires-python, shown for information)")
    for hole in holes:
        print(f"check_wheels: no wheel: {hole}", file=sys.stderr)
    return 1 if holes else 0


if __name__ == "__main__":
    sys.exit(main())
