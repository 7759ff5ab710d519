"""The figures in the docs come from one place: what `make bench --record` wrote in docs/figures.json,
put into the pages by docs/hooks/figures.py; a page that names a figure the file lacks fails the build."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path
from types import ModuleType

import pytest

from tests.helpers import ROOT as REPO


def load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


hook = load(REPO / "docs" / "hooks" / "figures.py")
bench = load(REPO / "tests" / "bench" / "run.py")


def test_a_page_gets_the_recorded_value_and_an_unknown_figure_fails_the_build(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "figures.json"
    bench.record({"startup.run_t1_s": 3.2104, "trust.readers": [16, 284]}, path)
    bench.record({"startup.help_s": 0.1}, path)  # a second run adds, and keeps what it did not measure
    monkeypatch.setattr(hook, "FIGURES", path)
    page = "T1 takes [[fig:startup.run_t1_s]] s; readers [[fig:trust.readers]].\n\n<!-- figures:all -->"
    out = hook.on_page_markdown(page)
    assert out.startswith("T1 takes 3.2104 s; readers [16, 284].")
    assert "    | `startup.help_s` | 0.1 |" in out and '??? note "`trust`: 1 figures"' in out  # folded per bench
    with pytest.raises(KeyError, match="no such figure"):
        hook.on_page_markdown("[[fig:startup.nothing]]")


def test_every_figure_a_page_names_is_recorded() -> None:
    recorded = json.loads((REPO / "docs" / "figures.json").read_text(encoding="utf-8"))["figures"]
    named = {
        key
        for page in (REPO / "docs").glob("*.md")
        for key in re.findall(r"\[\[fig:([A-Za-z0-9_\-]+\.[A-Za-z0-9_.\-]+)\]\]", page.read_text(encoding="utf-8"))
    }
    assert named, "the figures page names its figures"
    assert named <= set(recorded), sorted(named - set(recorded))
