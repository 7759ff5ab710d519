"""Build the MCP Bundle dist/robocog.mcpb (`make bundle`): manifest 0.4, server type `uv`.

The bundle holds packaging/bundle/manifest.json and server/main.py (the entry point), robocog's own
wheel under wheels/, a pyproject.toml that depends on that wheel, a .python-version, and the uv.lock
that pins every dependency to the version installed in this virtualenv (the versions the test suite
ran with) where it is installed, so a host's `uv run` installs the same set everywhere.

Wheels only, on every platform the manifest claims: the bundle's Python is `BUNDLE_PYTHON` (uv
fetches it where it is missing), its lock is solved for the environments of `PLATFORMS` and nothing
else (uv refuses to lock when a package has no wheel for one of them), and uv never builds a package
from source when it installs one. `packaging/check_wheels.py` (`make bundle-check`) resolves the lock
again for each platform and each Python the project allows, wheels only, and prints the matrix.

Building needs the package index (the wheel's build backend and `uv lock`); installing the bundle
needs it too, except where uv finds every package already installed (tests/e2e/test_packaging.py,
offline).

Usage: python packaging/build_bundle.py [--out dist/robocog.mcpb] [--stage build/bundle]
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import shutil
import subprocess
import sys
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "packaging" / "bundle"
# Files a host never needs: an environment, caches, the packer's own ignore list.
SKIPPED_NAMES = {".venv", "__pycache__", ".DS_Store", ".mcpbignore"}

#: The bundle's Python (a minor version): one, so that each platform below gets one physics build, and
#: this one, as upstream PyBullet (Linux's: pyproject.toml) has wheels for CPython 3.10-3.11 only; the fork
#: has them for 3.11 on macOS and Windows too. uv fetches it where the machine has another.
BUNDLE_PYTHON = "3.11"


@dataclass(frozen=True)
class Target:
    """A machine the bundle installs on from wheels: uv's name for it (`--python-platform`), its
    environment marker, and the oldest OS it covers (where uv takes one from the environment)."""

    triple: str
    marker: str
    env: tuple[tuple[str, str], ...] = ()


#: What each platform the manifest claims means. No wheel of the physics (Linux arm64, Windows on Arm)
#: or of mcp's cryptography (Intel Macs: 50.x has none) exists elsewhere; onnxruntime's arm64 Mac
#: wheels need macOS 14; onnxruntime's and the fork's Linux wheels glibc 2.28 (manylinux_2_28).
PLATFORMS: dict[str, tuple[Target, ...]] = {
    "darwin": (
        Target(
            "aarch64-apple-darwin",
            "sys_platform == 'darwin' and platform_machine == 'arm64'",
            (("MACOSX_DEPLOYMENT_TARGET", "14.0"),),
        ),
    ),
    "linux": (Target("x86_64-manylinux_2_28", "sys_platform == 'linux' and platform_machine == 'x86_64'"),),
    "win32": (Target("x86_64-pc-windows-msvc", "sys_platform == 'win32' and platform_machine == 'AMD64'"),),
}


def project_version() -> str:
    """The package's version, from pyproject.toml."""
    with open(ROOT / "pyproject.toml", "rb") as f:
        return str(tomllib.load(f)["project"]["version"])


def installed_pins() -> list[str]:
    """`name==version` for every distribution in this environment but robocog itself, sorted."""
    pins = {
        dist.metadata["Name"].lower(): dist.version
        for dist in importlib.metadata.distributions()
        if dist.metadata["Name"] and dist.metadata["Name"].lower() != "robocog"
    }
    return [f"{name}=={version}" for name, version in sorted(pins.items())]


def environments(platforms: list[str]) -> list[str]:
    """The markers of the environments the manifest's `platforms` claim (see `PLATFORMS`)."""
    unknown = sorted(set(platforms) - set(PLATFORMS))
    if unknown:
        raise SystemExit(f"build_bundle: manifest.json claims {', '.join(unknown)}: PLATFORMS names no target")
    return [target.marker for p in platforms for target in PLATFORMS[p]]


def bundle_pyproject(version: str, wheel: str, pins: list[str], markers: list[str]) -> str:
    """The bundle's pyproject.toml: a virtual project that depends on robocog's wheel in the bundle,
    on `BUNDLE_PYTHON`, locked for the environments `markers` with a wheel of every package in each."""
    constraints = "".join(f'    "{pin}",\n' for pin in pins)
    envs = "".join(f'    "{marker}",\n' for marker in markers)
    return (
        "# The MCP Bundle's project: `uv run` installs robocog from the wheel beside this file.\n"
        "[project]\n"
        'name = "robocog-bundle"\n'
        f'version = "{version}"\n'
        f'requires-python = "=={BUNDLE_PYTHON}.*"\n'
        f'dependencies = ["robocog=={version}"]\n\n'
        "[tool.uv]\n"
        "package = false\n"
        "# Wheels only: a host gives up long before a C++ build of PyBullet ends.\n"
        "no-build = true\n"
        "# The platforms manifest.json claims: the lock is solved for these, with a wheel of every package in each.\n"
        f"environments = [\n{envs}]\n"
        f"required-environments = [\n{envs}]\n"
        "# The versions robocog's test suite ran with (where they are installed there).\n"
        f"constraint-dependencies = [\n{constraints}]\n\n"
        "[tool.uv.sources]\n"
        f'robocog = {{ path = "wheels/{wheel}" }}\n'
    )


def uv_command() -> str:
    """The uv beside this interpreter (the dev extra installs it), else the one on PATH."""
    beside = Path(sys.executable).parent / "uv"
    found = str(beside) if beside.exists() else shutil.which("uv")
    if found is None:
        raise SystemExit("build_bundle: uv is not installed (pip install uv, or the dev extra)")
    return found


def stage(stage_dir: Path) -> Path:
    """Lay the bundle's files out in stage_dir (emptied first); returns stage_dir."""
    version = project_version()
    manifest = json.loads((SOURCE / "manifest.json").read_text())
    if manifest["version"] != version:
        raise SystemExit(f"build_bundle: manifest.json has version {manifest['version']}, pyproject.toml {version}")
    shutil.rmtree(stage_dir, ignore_errors=True)
    (stage_dir / "server").mkdir(parents=True)
    shutil.copy2(SOURCE / "manifest.json", stage_dir / "manifest.json")
    shutil.copy2(SOURCE / "server" / "main.py", stage_dir / "server" / "main.py")
    shutil.copy2(SOURCE / "README.md", stage_dir / "README.md")
    shutil.copy2(SOURCE / ".mcpbignore", stage_dir / ".mcpbignore")
    wheels = stage_dir / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--wheel-dir", str(wheels), str(ROOT)],
        check=True,
    )
    (wheel,) = [p.name for p in wheels.glob("robocog-*.whl")]
    markers = environments(manifest["compatibility"]["platforms"])
    (stage_dir / "pyproject.toml").write_text(bundle_pyproject(version, wheel, installed_pins(), markers))
    (stage_dir / ".python-version").write_text(f"{BUNDLE_PYTHON}\n")
    subprocess.run([uv_command(), "lock", "--quiet", "--project", str(stage_dir)], check=True)
    return stage_dir


def pack(stage_dir: Path, out: Path) -> Path:
    """Zip stage_dir into out (an .mcpb is a zip with manifest.json at its root)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        for path in sorted(stage_dir.rglob("*")):
            if path.is_file() and not SKIPPED_NAMES.intersection(path.relative_to(stage_dir).parts):
                zf.write(path, path.relative_to(stage_dir).as_posix())
    return out


def main() -> None:
    """Stage and pack the bundle; print where it is and its size."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "dist" / "robocog.mcpb")
    parser.add_argument("--stage", type=Path, default=ROOT / "build" / "bundle")
    args = parser.parse_args()
    out = pack(stage(args.stage), args.out)
    print(f"{out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}: {out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
