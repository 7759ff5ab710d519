"""The robot app's page (assets/app/robot.html) is what its sources build: `node assets/app/build.mjs
--check` bundles assets/app/src (ext-apps' App, the live viewer's map renderer) with the pinned esbuild
and compares. The sources write every name as text, never as HTML."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from tests.helpers import ROOT

APP = ROOT / "assets" / "app"
MODULES = ROOT / ".cache" / "app" / "node_modules"


def node() -> str:
    path = shutil.which("node")
    if path is None:
        pytest.skip("node is missing: checking that assets/app/robot.html is what its sources build needs Node.js")
    if not (MODULES / "esbuild").is_dir() or not (MODULES / "@modelcontextprotocol" / "ext-apps").is_dir():
        pytest.skip("the robot app's build tools are not installed: `make app-deps` (make test does it)")
    return path


def test_the_committed_page_is_what_its_sources_build() -> None:
    done = subprocess.run([node(), str(APP / "build.mjs"), "--check"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr + done.stdout


def test_the_page_is_one_self_contained_file_with_the_library_license_beside_it() -> None:
    page = (APP / "robot.html").read_text(encoding="utf-8")
    assert "ext-apps.LICENSE.txt" in page and "Apache License" in (APP / "ext-apps.LICENSE.txt").read_text()
    assert not re.search(r"<(script|link|img|iframe)[^>]+(src|href)=", page), "nothing is loaded from elsewhere"
    assert page.count("<script>") == 1 and "RobocogMap" in page, "the live viewer's map renderer, bundled"


def test_the_sources_write_names_as_text_never_as_html() -> None:
    for source in [*sorted((APP / "src").glob("*.js")), ROOT / "assets" / "viewer" / "map.js"]:
        code = source.read_text(encoding="utf-8")
        for sink in ("innerHTML", "outerHTML", "insertAdjacentHTML", "document.write", "eval("):
            assert sink not in code, f"{source.name} uses {sink}"
