"""The shape of the code: the import contracts hold (import-linter, as `make lint` runs it), no module
reaches into another's private names, no two modules import each other (not even from inside a
function), no source or test file grows past 400 lines, and reading results
(`robocog report`, `robocog view`, `robocog --help`) starts without the MCP SDK, LiteLLM or PyBullet."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT

#: The source folders (the published packages), as the repository lays them out.
SOURCES = ("agent", "server", "shared", "integrations/inspect")
#: The tests (every tier, their support code, the benches).
TESTS = "tests"
#: No source or test file is longer than this.
MAX_LINES = 400
#: Where import-linter finds `robocog` as a plain package tree (`make lint` lays it out).
TYPE_TREE = ROOT / "build" / "typecheck"


def source_files() -> list[Path]:
    return sorted(p for folder in SOURCES for p in (ROOT / folder).rglob("*.py"))


def module_name(path: Path) -> str:
    relative = path.relative_to(ROOT).with_suffix("")
    parts = list(relative.parts)
    if parts[:2] == ["integrations", "inspect"]:
        parts = ["inspect", *parts[2:]]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(["robocog", *parts])


def test_the_import_contracts_hold() -> None:
    if not (TYPE_TREE / "robocog").exists():
        pytest.skip("make lint lays out build/typecheck/robocog, which import-linter reads")
    lint = Path(sys.executable).parent / "lint-imports"
    if not lint.exists():
        pytest.skip("import-linter is not installed (pip install -e '.[dev]')")
    env = {**os.environ, "PYTHONPATH": str(TYPE_TREE)}
    done = subprocess.run(
        [str(lint), "--no-cache"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert "0 broken" in done.stdout


def test_no_module_imports_a_private_name_of_another() -> None:
    offenders = []
    for path in source_files():
        here = module_name(path)
        package = here if path.name == "__init__.py" else here.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom) or node.module is None:
                continue
            source = node.module if node.level == 0 else f"{package.rsplit('.', node.level - 1)[0]}.{node.module}"
            if not source.startswith("robocog") or source == here:
                continue
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}: {source}.{alias.name}")
    assert offenders == []


def imported_modules() -> dict[str, set[str]]:
    """Each source module and the robocog modules it imports anywhere in it (in a function, under
    TYPE_CHECKING too): `from P import M` counts as importing the module P.M where M is one."""
    modules = {module_name(p): p for p in source_files()}
    edges: dict[str, set[str]] = {}
    for here, path in modules.items():
        package = here if path.name == "__init__.py" else here.rpartition(".")[0]
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                found |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join([package.rsplit(".", node.level - 1)[0], *([base] if base else [])])
                found |= {f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names}
        edges[here] = {m for m in found if m in modules and m != here}
    return edges


def test_no_two_modules_import_each_other() -> None:
    edges = imported_modules()
    pairs = sorted({tuple(sorted((a, b))) for a, out in edges.items() for b in out if a in edges.get(b, set())})
    assert pairs == []


def test_the_servers_root_holds_at_most_twelve_modules_the_rest_grouped_by_job() -> None:
    root = sorted(p.stem for p in (ROOT / "server").glob("*.py") if p.stem != "__init__")
    assert len(root) <= 12, root


def test_no_source_or_test_file_is_longer_than_400_lines() -> None:
    files = [*source_files(), *sorted((ROOT / TESTS).rglob("*.py"))]
    long = {
        str(p.relative_to(ROOT)): n for p in files if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}


def test_reading_results_imports_neither_mcp_nor_litellm_nor_pybullet() -> None:
    probe = (
        "import sys\n"
        "import robocog.agent.cli.main as cli\n"
        "cli.build_parser()\n"
        "import robocog.agent.cli.report, robocog.agent.analysis.report, robocog.agent.analysis.results_file\n"
        "import robocog.agent.view.serve, robocog.agent.view.bundle, robocog.agent.view.leaderboard_page\n"
        "import robocog.agent.cli.leaderboard, robocog.agent.cli.submit, robocog.agent.analysis.submission\n"
        "heavy = ('mcp', 'litellm', 'pybullet', 'chromadb')\n"
        "print(sorted({m.split('.')[0] for m in sys.modules if m.split('.')[0] in heavy}))\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"
