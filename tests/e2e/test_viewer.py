"""The viewers: both pages in a real browser, and the flags that start them.

The browser tests drive Debian's Chromium, headless, through Playwright (the `browser` extra;
Playwright cannot download its own browser here, so it is pointed at the system's). Without
Chromium or Playwright they skip and say how to install them. Screenshots are kept under
build/screenshots/ as test artifacts. The event bus behind the live page is tested in
test_event_bus.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.browser import browser_page, chromium, screenshot_path, serving
from tests.helpers import DATA, live_server

# --- the live viewer in a browser ------------------------------------------------------------------


@pytest.mark.anyio
async def test_live_viewer_follows_a_client_over_stdio(tmp_path: Path) -> None:
    chromium()  # skips, saying how to install it, where there is no browser
    async with live_server(tmp_path / "memory", "--profile", "eval") as (client, url), browser_page() as page:
        await page.goto(url)
        await page.wait_for_function("document.body.dataset.ready === 'true'", timeout=60_000)
        assert await page.title() == "robocog · live"
        start = await page.eval_on_selector("#map", "m => m.dataset.location")
        assert start == await page.text_content("#robot-location")
        assert start != "Kitchen Shelf"

        grabbed = await client.call_tool("grab", {"object": "cube"})
        assert not grabbed.is_error, grabbed.content
        await page.wait_for_function("document.getElementById('robot-holding').textContent === 'cube'")

        moved = await client.call_tool("move_to", {"location": "Kitchen Shelf"})
        assert not moved.is_error, moved.content
        await page.wait_for_function("document.getElementById('map').dataset.location === 'Kitchen Shelf'")
        x = float(await page.eval_on_selector("#map", "m => m.dataset.robotX"))
        y = float(await page.eval_on_selector("#map", "m => m.dataset.robotY"))
        assert abs(x - 1.0) < 0.3 and abs(y - 4.85) < 0.3  # the shelf's spot on the map

        row = page.locator("#stream li[data-tool='move_to']")
        await row.locator(".summary").filter(has_text="Kitchen Shelf").wait_for()
        assert "location=Kitchen Shelf" in (await row.locator(".args").text_content() or "")
        assert await row.get_attribute("class") == "call done"

        looked = await client.call_tool("look", {"direction": "left"})
        assert not looked.is_error, looked.content
        picture = page.locator("#stream li[data-tool='look'] img.thumb")
        await picture.wait_for()
        await page.wait_for_function("document.querySelector('#stream img.thumb').naturalWidth > 0")
        await page.wait_for_function("(document.getElementById('camera').dataset.shows || '').includes('/api/images/')")
        assert "what the agent saw" in (await page.text_content("#camera-caption") or "")

        await client.call_tool("end_task", {"status": "success", "description": "T1", "summary": "tidied up"})
        await client.call_tool("check_task", {"task_id": "T1"})
        await page.wait_for_function("document.getElementById('verdict').dataset.truth === 'false'")
        assert await page.get_attribute("#verdict", "data-believed") == "success"
        assert await page.locator("#stream li").count() == 5

        await page.wait_for_function("document.getElementById('camera').naturalWidth === 320")
        await page.screenshot(path=str(screenshot_path("live-viewer.png")))


# --- the results viewer ----------------------------------------------------------------------------


def study_with_a_trace(folder: Path) -> Path:
    """The committed small results file, its first attempt given a trace with a picture (as
    `robocog eval` and the camera write them: TRACE.jsonl, TRACE.images/NNNN-look.png)."""
    import numpy as np

    from robocog.server.world.camera import encode_png
    from robocog.shared.trace import ModelTurn, RunFinished, RunStarted, ToolCall, ToolResult, Verdict, dump_event

    rows = [json.loads(line) for line in (DATA / "results_small.jsonl").read_text().splitlines() if line.strip()]
    traces = folder / "results.traces" / "alpha" / "trial-0"
    (traces / "iter-0-T1.images").mkdir(parents=True)
    pixels = np.zeros((24, 32, 3), dtype=np.uint8)
    pixels[:, :16] = (200, 40, 40)
    (traces / "iter-0-T1.images" / "0001-look.png").write_bytes(encode_png(pixels))
    events = [
        RunStarted(
            t=0, task="Put away all the items into the shelf.", model="alpha/model", server="test", tools=["look"]
        ),
        ModelTurn(
            t=0.5, invocation=1, step=1, message={"role": "assistant", "content": "I will look first."}, latency_s=0.5
        ),
        ToolCall(t=0.6, invocation=1, id="c1", name="look", arguments={"direction": "ahead"}, raw_arguments="{}"),
        ToolResult(
            t=0.7,
            invocation=1,
            id="c1",
            name="look",
            is_error=False,
            content='{"status": "success", "message": "a red cube ahead"}',
            structured={"status": "success", "message": "a red cube ahead"},
            latency_s=0.05,
            images=["iter-0-T1.images/0001-look.png"],
        ),
        Verdict(t=0.8, task_id="T1", success=True, reason="hand-made"),
        RunFinished(
            t=0.9,
            outcome="ended",
            ended=True,
            stopped=False,
            believed_success=True,
            true_success=True,
            invocations=1,
            tool_calls=1,
            tokens_in=10,
            tokens_out=5,
            llm_latency_s=0.5,
            wall_s=0.9,
        ),
    ]
    (traces / "iter-0-T1.jsonl").write_text("".join(dump_event(e) + "\n" for e in events) + "not json\n")
    rows[0]["trace"] = "results.traces/alpha/trial-0/iter-0-T1.jsonl"
    # the last attempt an infeasible instance's honest failure: a success, no request achieved
    rows[-1].update(feasible=False, true_success=True, believed_success=False)
    rows[1]["trace"] = "../outside.jsonl"  # never read: outside the results file's folder
    results = folder / "results.jsonl"
    results.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return results


@pytest.mark.anyio
async def test_results_viewer_lists_the_attempts_and_opens_a_trace(tmp_path: Path) -> None:
    from robocog.agent.view.serve import ResultsViewer

    chromium()  # skips, saying how to install it, where there is no browser
    viewer = ResultsViewer(study_with_a_trace(tmp_path))
    viewer.prepare()
    try:
        async with serving(viewer.app()) as url, browser_page() as page:
            await page.goto(url)
            await page.wait_for_function("document.body.dataset.ready === 'true'")
            rows = page.locator("#attempts tbody tr")
            assert await rows.count() == 13
            assert await page.text_content("#shown-count") == "13 of 13 attempts"
            await page.select_option("#f-model", "beta")
            beta = await rows.count()
            assert 0 < beta < 13
            assert set(await page.locator("#attempts tbody tr td:nth-child(2)").all_text_contents()) == {"beta"}
            await page.select_option("#f-model", "")
            await page.select_option("#f-truth", "false")
            assert await page.locator("#attempts tbody tr td:nth-child(8)").all_text_contents() == ["failure"] * (
                await rows.count()
            )
            await page.select_option("#f-truth", "")
            achieved = await page.locator("#attempts tbody tr td:nth-child(9)").all_text_contents()
            truth = await page.locator("#attempts tbody tr td:nth-child(8)").all_text_contents()
            assert achieved[-1] == "infeasible" and truth[-1] == "success"
            assert [a == "yes" for a in achieved[:-1]] == [t == "success" for t in truth[:-1]]
            assert await page.locator("#attempts thead th:nth-child(9)").text_content() == "achieved"

            await rows.first.click()
            steps = page.locator("#steps li")
            await steps.first.wait_for()
            kinds = [await s.get_attribute("data-type") for s in await steps.all()]
            assert kinds == [
                "run_started",
                "model_turn",
                "tool_call",
                "tool_result",
                "verdict",
                "run_finished",
                "unreadable",
            ]
            picture = page.locator("#steps li[data-type='tool_result'] img")
            await page.wait_for_function("document.querySelector('#steps img').naturalWidth === 32")
            assert "0001-look.png" in (await picture.get_attribute("alt") or "")
            assert page.url.endswith("#attempt=0")
            await page.screenshot(path=str(screenshot_path("results-viewer.png")))

            outside = await page.request.get(url + "api/attempts/1/trace")
            assert outside.status == 404
            escape = await page.request.get(url + "api/attempts/0/files/..%2F..%2F..%2F..%2Fresults.jsonl")
            assert escape.status == 404

            await page.click("#tab-report")
            report = page.locator("#pane-report")
            assert "Success" in (await report.text_content() or "")
            assert await report.locator("table").count() > 0
            await page.wait_for_function(
                "[...document.querySelectorAll('#pane-report img')].some(i => i.naturalWidth > 0)"
            )
            await page.screenshot(path=str(screenshot_path("results-report.png")), full_page=False)
    finally:
        viewer.close()


def test_view_command_refuses_a_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from robocog.agent.cli.main import main

    assert main(["view", str(tmp_path / "nothing.jsonl")]) == 2
    assert "no such results file" in capsys.readouterr().err


def test_run_passes_view_to_the_server_it_spawns() -> None:
    from robocog.agent.cli.main import build_parser
    from robocog.agent.cli.options import check_options as _check_options
    from robocog.agent.cli.options import server_spec as _server_spec
    from robocog.shared.errors import ConfigError

    spec = _server_spec(build_parser().parse_args(["run", "T1", "--view"]))
    assert spec.extra_args[-2:] == ["--view", "8766"]
    spec = _server_spec(build_parser().parse_args(["run", "T1", "--view", "9001"]))
    assert spec.extra_args[-2:] == ["--view", "9001"]
    remote = build_parser().parse_args(["run", "T1", "--view", "--url", "http://127.0.0.1:8765/mcp"])
    with pytest.raises(ConfigError, match="--view"):
        _check_options(remote)


def test_server_view_flag() -> None:
    from robocog.server.cli_options import build_parser

    parser = build_parser()
    assert parser.parse_args([]).view is None
    assert parser.parse_args(["--view"]).view == 8766
    assert parser.parse_args(["--view", "0"]).view == 0
    with pytest.raises(SystemExit):
        parser.parse_args(["--view", "70000"])
