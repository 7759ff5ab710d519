"""The static results bundle (`robocog view RESULTS --bundle DIR`) opened from file:// in Chromium:
the attempts, a trace step by step with its picture, the report with its figures; and a real study's
rows, whose provenance is that of what robocog ships (the physics build the server announced among
it, and a report that marks rows of another), bundled whole.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robocog.agent.analysis.provenance import row_problems, trace_on_disk, verify
from robocog.agent.analysis.report import render
from robocog.agent.analysis.results_file import read_rows
from robocog.agent.cli.main import main
from robocog.shared.provenance import physics_build
from tests.browser import browser_page, chromium, screenshot_path
from tests.e2e.test_viewer import study_with_a_trace
from tests.helpers import ROOT

CONFIG = ROOT / "assets" / "eval" / "scripted.yaml"


def eval_study(out: Path, *flags: str, config: Path = CONFIG) -> Path:
    """A small study (by default of the scripted models), written by `robocog eval` (its traces beside it)."""
    command = [sys.executable, "-m", "robocog.agent.cli", "eval", str(config), "--out", str(out), "--quiet", *flags]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The scripted study with 2 trials, 1 memory iteration (10 attempts: the refuser runs no T2)."""
    return eval_study(tmp_path_factory.mktemp("study") / "scripted.jsonl", "--trials", "2", "--memory-iterations", "1")


def test_eval_rows_carry_the_provenance_of_what_robocog_ships(study: Path) -> None:
    rows = read_rows(study)
    assert len(rows) == 10
    for r in rows:
        assert r.provenance is not None
        assert row_problems(r) == [], (r.model, r.task)
        assert r.provenance.system_prompt == "robot_system" and "look" not in r.provenance.tools
        assert r.provenance.physics == physics_build() is not None  # as the server announced it
    overconfident = {json.dumps(r.provenance.params) for r in rows if r.model == "overconfident-0.3" and r.provenance}
    assert overconfident == {'{"p": 0.3}'}
    assert verify(rows, trace_on_disk(study.parent)).verified


def test_the_report_marks_rows_of_another_physics_build(study: Path, tmp_path: Path) -> None:
    rows = read_rows(study)
    assert rows[0].provenance is not None
    fork = rows[0].provenance.model_copy(update={"physics": "pybullet-arm64 3.2.8"})
    mixed = [rows[0].model_copy(update={"provenance": fork}), *rows[1:]]
    report = render(mixed, tmp_path / "report").read_text(encoding="utf-8")
    said = f"- rows disagree on the physics build: {physics_build()} (9 rows), pybullet-arm64 3.2.8 (1 rows)"
    assert said in report.split("## Provenance: the rows disagree", 1)[1]
    assert "## Provenance" not in render(rows, tmp_path / "same").read_text(encoding="utf-8")


def _open(path: Path) -> str:
    return path.resolve().as_uri()


@pytest.mark.anyio
async def test_a_bundle_opened_from_disk_shows_attempts_traces_pictures_and_the_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    chromium()
    results = study_with_a_trace(tmp_path / "study")
    bundle = tmp_path / "site"
    assert main(["view", str(results), "--bundle", str(bundle)]) == 0
    said = capsys.readouterr().out
    assert said.startswith(f"bundle: {bundle / 'index.html'} (") and "1 traces, 1 pictures" in said
    assert (bundle / "files" / "0" / "iter-0-T1.images" / "0001-look.png").is_file()
    assert not (bundle / "data" / "traces" / "1.js").exists()  # its trace is outside the study's folder
    html = (bundle / "index.html").read_text()
    assert '"/' not in html  # every address relative: any static host, any folder
    async with browser_page() as page:
        problems: list[str] = []
        page.on("pageerror", lambda e: problems.append(str(e)))
        await page.goto(_open(bundle / "index.html") + "#attempt=0")
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        assert await page.locator("#attempts tbody tr").count() == 13
        steps = page.locator("#steps li")
        await steps.first.wait_for()  # #attempt=0 opened it
        assert await steps.count() == 7
        await page.wait_for_function("document.querySelector('#steps img').naturalWidth === 32")
        await page.screenshot(path=str(screenshot_path("bundle-trace.png")))

        await page.locator("#attempts tbody tr").nth(1).click()  # a row whose trace is not in the bundle
        assert await page.locator("#steps").count() == 1  # nothing happens: the row is not clickable
        await page.click("#tab-report")
        await page.wait_for_function(
            "[...document.querySelectorAll('#pane-report img')].length > 3 && "
            "[...document.querySelectorAll('#pane-report img')].every(i => i.complete && i.naturalWidth > 0)"
        )
        assert problems == []


@pytest.mark.anyio
async def test_a_real_study_bundles_whole_and_each_trace_opens(study: Path, tmp_path: Path) -> None:
    chromium()
    bundle = tmp_path / "site"
    assert main(["view", str(study), "--bundle", str(bundle)]) == 0
    assert len(list((bundle / "data" / "traces").glob("*.js"))) == 10
    assert main(["view", str(study), "--bundle", str(bundle)]) == 0  # written again over itself
    async with browser_page() as page:
        await page.goto(_open(bundle / "index.html"))
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        rows = read_rows(study)
        for index in range(len(rows)):  # every trace opens whole; the refuser's has no tool call
            await page.locator(f"#attempts tbody tr[data-index='{index}']").click()
            await page.wait_for_function(f"document.getElementById('trace-pane').dataset.open === '{index}'")
            kinds = await page.locator("#steps li").evaluate_all("items => items.map(i => i.dataset.type)")
            assert kinds[0] == "run_started" and kinds[-1] == "run_finished"
            assert ("tool_call" in kinds) == (rows[index].model != "refuser"), (index, rows[index].model)


def test_bundle_refuses_bad_input_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["view", str(tmp_path / "nothing.jsonl"), "--bundle", str(tmp_path / "b")]) == 2
    assert capsys.readouterr().err.strip() == f"robocog: {tmp_path / 'nothing.jsonl'}: no such results file"
    garbage = tmp_path / "garbage.jsonl"
    garbage.write_text('{"model": "x"}\nnot json\n{"model": "y"}\n')
    assert main(["view", str(garbage), "--bundle", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a results file of robocog eval (line 1: " in err
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("mine")
    good = study_with_a_trace(tmp_path / "study")
    assert main(["view", str(good), "--bundle", str(busy)]) == 2
    assert "holds something else than a bundle" in capsys.readouterr().err
    assert (busy / "notes.txt").read_text() == "mine"
