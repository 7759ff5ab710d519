"""robocog.agent's public API: every exported name resolves, importing the package costs neither the
MCP SDK nor LiteLLM, and the example in its docstring runs as written against a real server."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import robocog.agent


def test_every_exported_name_resolves() -> None:
    for name in robocog.agent.__all__:
        assert getattr(robocog.agent, name) is not None


def test_importing_the_package_defers_the_slow_imports() -> None:
    probe = "import sys, robocog.agent; print(sorted(m for m in ('mcp', 'litellm', 'pybullet') if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_a_scripted_run_never_imports_litellm(tmp_path: Path) -> None:
    """The offline models are answered in-process: `robocog run T1 --model scripted/planner` pays
    neither LiteLLM's import (seconds) nor its per-call wrapper."""
    probe = (
        "import sys; from robocog.agent.cli.main import main; code = main(['run', 'T1', '--model', "
        f"'scripted/planner', '--quiet', '--data-dir', {str(tmp_path / 'memory')!r}]); "
        "print(code, 'litellm' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=180, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-2:] == ["0", "False"], done.stdout


def test_the_docstring_example_runs_as_written(tmp_path: Path) -> None:
    doc = robocog.agent.__doc__ or ""
    block = re.search(r"::\n\n((?:    .*\n|\n)+)", doc)
    assert block is not None
    code = "\n".join(line[4:] for line in block.group(1).splitlines())
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=180,
        cwd=tmp_path,
        env={"ROBOCOG_DATA_DIR": str(tmp_path / "memory"), "PATH": str(Path(sys.executable).parent)},
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["ended", "True", "18"]
