"""The MCP Inspector's CLI, a client with no robocog code in it, as the tests drive it."""

from __future__ import annotations

import json
import os
import subprocess
from typing import Any

import pytest

from tests.helpers import ROOT

#: The MCP Inspector's CLI, installed by `make inspector-cli` (`make test` does it where Node.js is).
INSPECTOR = ROOT / ".cache" / "inspector" / "node_modules" / ".bin" / "mcp-inspector"


def inspector(url: str, *method: str) -> dict[str, Any]:
    """What the MCP Inspector's CLI (no robocog code) answers for `--method *method` against the HTTP
    server at `url`; skips the test when the CLI is not installed."""
    if not INSPECTOR.exists():
        pytest.skip("the MCP Inspector's CLI is not installed: `make inspector-cli` installs it (needs Node.js)")
    out = subprocess.run(
        [str(INSPECTOR), "--cli", url, "--transport", "http", "--method", *method],
        capture_output=True,
        text=True,
        timeout=90,
        env={**os.environ, "NO_COLOR": "1"},
    )
    assert out.returncode == 0, out.stderr[-2000:]
    answer: dict[str, Any] = json.loads(out.stdout[out.stdout.index("{") :])
    return answer
