"""The live viewer shows what goes wrong as it happens: a marked row for each perturbation (announced
or silent) in the list of calls, a blocked corridor crossed out on the map while it lasts, and the
map's furniture that opens with its state and contents.

Headless Chromium through Playwright, as tests/e2e/test_viewer.py; the screenshot lands in
build/screenshots/live-viewer-perturbations.png.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.browser import browser_page, chromium, screenshot_path, serving
from tests.helpers import live_server

PERTURBATIONS = [
    {"kind": "close_container", "container": "kitchen_drawer", "at_call": 3, "announce": True},
    {"kind": "block_edge", "edge": ["Kitchen Area Left", "Kitchen Table"], "at_call": 4, "duration": 2},
]


@pytest.mark.anyio
async def test_the_live_viewer_marks_perturbations_and_draws_containers(tmp_path: Path) -> None:
    chromium()  # skips, saying how to install it, where there is no browser
    args = ("--profile", "eval", "--scene", "kitchen_plus")
    async with live_server(tmp_path / "memory", *args) as (client, url), browser_page() as page:
        await page.goto(url)
        await page.wait_for_function("document.body.dataset.ready === 'true'", timeout=60_000)
        reset = await client.call_tool("reset_world", {"perturbations": PERTURBATIONS})
        assert not reset.is_error, reset.content
        for tool, arguments in [
            ("move_to", {"location": "Kitchen Drawer"}),
            ("open", {"furniture": "kitchen_drawer"}),
        ]:
            result = await client.call_tool(tool, arguments)
            assert not result.is_error, result.content
        await page.wait_for_function(
            "(document.getElementById('map').dataset.furniture || '').includes('\"kitchen_drawer\",\"open\"')"
        )
        await client.call_tool("move_to", {"location": "Kitchen Area Left"})  # someone closes the drawer
        blocked = await client.call_tool("move_to", {"location": "Kitchen Table"})  # the way is blocked
        assert blocked.is_error

        closed = page.locator("#stream li.perturbation[data-kind='close_container']")
        await closed.wait_for()
        assert "Someone closed the kitchen drawer." in (await closed.locator(".summary").text_content() or "")
        assert await closed.locator(".tag").text_content() == "announced"
        block = page.locator("#stream li.perturbation[data-kind='block_edge']")
        await block.wait_for()
        assert await block.locator(".tag").text_content() == "silent"
        await page.wait_for_function(
            "(document.getElementById('map').dataset.furniture || '').includes('\"kitchen_drawer\",\"closed\"')"
        )
        drawn = json.loads(await page.eval_on_selector("#map", "m => m.dataset.furniture"))
        assert ["kitchen_drawer", "closed", ["sponge"]] in drawn and ["fridge", "closed", ["bottle"]] in drawn
        # The newest rows first: the block above the call it stopped, the closing above its call.
        rows = await page.eval_on_selector_all("#stream li", "ls => ls.map(l => l.dataset.kind || l.dataset.tool)")
        assert rows[:4] == ["block_edge", "move_to", "close_container", "move_to"]
        blocked_edge = '[["Kitchen Area Left","Kitchen Table"]]'
        assert await page.eval_on_selector("#map", "m => m.dataset.blocked") == blocked_edge
        await page.screenshot(path=str(screenshot_path("live-viewer-perturbations.png")))
        for _ in range(2):  # calls 5 and 6: the block (calls 4 and 5) lifts as call 6 begins
            await client.call_tool("look_around", {})
        await page.locator("#stream li.perturbation[data-kind='block_edge']").nth(1).wait_for()
        await page.wait_for_function("document.getElementById('map').dataset.blocked === '[]'")


@pytest.mark.anyio
async def test_the_results_viewer_shows_a_traces_perturbation_as_a_marked_step(tmp_path: Path) -> None:
    from robocog.agent.view.serve import ResultsViewer
    from robocog.shared.perturbations import PerturbationEvent
    from robocog.shared.trace import Perturbed, dump_event
    from tests.e2e.test_viewer import study_with_a_trace

    chromium()
    results = study_with_a_trace(tmp_path)
    trace = tmp_path / "results.traces" / "alpha" / "trial-0" / "iter-0-T1.jsonl"
    lines = trace.read_text().splitlines(keepends=True)
    slipped = PerturbationEvent(kind="slip", call=1, description="The cube slipped out of the hand.", announced=False)
    lines.insert(4, dump_event(Perturbed(t=0.75, invocation=1, id="c1", event=slipped)) + "\n")
    trace.write_text("".join(lines))
    viewer = ResultsViewer(results)
    viewer.prepare()
    async with serving(viewer.app()) as url, browser_page() as page:
        await page.goto(url)
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        await page.locator("#attempts tbody tr").first.click()
        step = page.locator("#steps li[data-type='perturbation']")
        await step.wait_for()
        assert "The cube slipped out of the hand." in (await step.text_content() or "")
        assert await step.locator(".tag").text_content() == "silent"
        kinds = [await s.get_attribute("data-type") for s in await page.locator("#steps li").all()]
        assert kinds[3:5] == ["tool_result", "perturbation"]
