"""The two viewers as a newcomer meets them, in Chromium: what each shows after the first-contact
fixes. Screenshots go to build/screenshots/first-contact-*.png.

Results viewer: a tool result shows what it holds beyond its message (search_memory's records,
look_around's state); the address's #attempt=N opens that attempt on an open page; a trace whose row a
filter hides is closed; a suite study (70 instances, long ids) fits 1400 px and filters by family.
Live viewer: the header counts the agent's tool calls (not a harness's begin_task and check_task); a
location's name is readable with the robot standing on it; the camera at the TV is not half black.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from tests.browser import browser_page, screenshot_path, serving
from tests.helpers import DATA, live_server

pytestmark = pytest.mark.anyio


def shot(name: str) -> str:
    return str(screenshot_path(f"first-contact-{name}.png"))


# --- the results viewer ---------------------------------------------------------------------------------


def trace_with_tool_results(path: Path) -> None:
    """A trace whose search_memory and look_around results hold more than their message."""
    from robocog.shared.trace import RunFinished, RunStarted, ToolCall, ToolResult, dump_event

    memory = {
        "status": "success",
        "message": "Found 1 past experience.",
        "results": [
            {
                "task_description": "Put away all the items into the shelf.",
                "status": "success",
                "summary": "cube on top",
            }
        ],
    }
    state = {"status": "success", "message": "The robot is at Front Door.", "location": "Front Door", "here": ["cube"]}
    events = [
        RunStarted(t=0, task="Put away all the items into the shelf.", model="m", server="test", tools=[]),
        ToolCall(t=0.1, invocation=1, id="a", name="search_memory", arguments={"query": "shelf"}, raw_arguments="{}"),
        ToolResult(
            t=0.2, invocation=1, id="a", name="search_memory", is_error=False,
            content=json.dumps(memory), structured=memory, latency_s=0.01,
        ),
        ToolCall(t=0.3, invocation=1, id="b", name="look_around", arguments={}, raw_arguments="{}"),
        ToolResult(
            t=0.4, invocation=1, id="b", name="look_around", is_error=False,
            content=json.dumps(state), structured=state, latency_s=0.01,
        ),
        RunFinished(
            t=0.5, outcome="stopped", ended=False, stopped=True, believed_success=None, true_success=False,
            invocations=1, tool_calls=2, tokens_in=0, tokens_out=0, llm_latency_s=0, wall_s=0.5,
        ),
    ]  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(dump_event(e) + "\n" for e in events), encoding="utf-8")


def small_study(folder: Path) -> Path:
    rows = [json.loads(line) for line in (DATA / "results_small.jsonl").read_text().splitlines() if line.strip()]
    for index in (0, 1):
        trace_with_tool_results(folder / f"t{index}.jsonl")
        rows[index]["trace"] = f"t{index}.jsonl"
    results = folder / "results.jsonl"
    results.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    return results


def suite_study(folder: Path) -> Path:
    """70 attempts over seven families, with the long model and instance ids a suite study has."""
    base = json.loads((DATA / "results_small.jsonl").read_text().splitlines()[0])
    families = ["put_away", "swap", "bring", "rearrange", "stack_order", "clear_surface", "multi_step_long"]
    rows = []
    for n in range(70):
        family = families[n % 7]
        task = f"dev-{family}-{n:03d}"
        model = "openrouter/meta-llama/llama-3.3-70b-instruct" if n % 2 else "anthropic/claude-sonnet-4-20250514"
        rows.append(base | {"task": task, "family": family, "instance": task, "model": model, "trial": n % 3})
    results = folder / "suite.jsonl"
    results.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    return results


async def test_results_viewer_shows_tool_results_follows_the_address_and_closes_a_filtered_trace(
    tmp_path: Path,
) -> None:
    from robocog.agent.view.serve import ResultsViewer

    viewer = ResultsViewer(small_study(tmp_path))
    viewer.prepare()
    try:
        async with serving(viewer.app()) as url, browser_page() as page:
            await page.goto(url + "#attempt=0")
            await page.wait_for_function("document.body.dataset.ready === 'true'")
            records = page.locator("#steps li[data-type='tool_result'] ul.records li")
            await records.first.wait_for()
            assert "Put away all the items into the shelf." in (await records.first.text_content() or "")
            look = page.locator("#steps li[data-type='tool_result']").nth(1)
            await look.locator("details summary").click()
            assert '"here"' in (await look.locator("details pre").text_content() or "")
            await page.screenshot(path=shot("results-tool-details"))

            await page.evaluate("location.hash = '#attempt=1'")  # typed in the address bar of an open page
            await page.wait_for_function("document.getElementById('trace-pane').dataset.open === '1'")
            assert await page.locator("#attempts tbody tr.selected td").first.text_content() == "1"

            model = await page.locator("#attempts tbody tr.selected td").nth(1).text_content()
            other = next(
                o for o in await page.locator("#f-model option").all_text_contents() if o not in ("all", model)
            )
            await page.select_option("#f-model", other)  # row 1 is filtered away: its trace goes too
            await page.wait_for_function("!document.getElementById('trace-pane').dataset.open")
            assert "Pick an attempt" in (await page.text_content("#trace-pane") or "")
            assert "#attempt" not in page.url
    finally:
        viewer.close()


async def test_results_viewer_fits_a_suite_study_and_filters_by_family(tmp_path: Path) -> None:
    from robocog.agent.view.serve import ResultsViewer

    viewer = ResultsViewer(suite_study(tmp_path))
    viewer.prepare()
    try:
        async with serving(viewer.app()) as url, browser_page(1400, 900) as page:
            await page.goto(url)
            await page.wait_for_function("document.body.dataset.ready === 'true'")
            await page.screenshot(path=shot("results-suite"))
            wrap = "document.querySelector('.list-wrap')"
            widths = await page.evaluate(f"[{wrap}.scrollWidth, {wrap}.clientWidth]")
            assert widths[0] <= widths[1], f"the table overflows: {widths}"
            assert not await page.locator("#family-filter").is_hidden()
            assert await page.locator("#f-task option").count() == 71  # all, and 70 instances
            await page.select_option("#f-family", "swap")
            tasks = await page.locator("#f-task option").all_text_contents()
            assert tasks[0] == "all" and len(tasks) == 11 and all("-swap-" in t for t in tasks[1:])
            assert await page.text_content("#shown-count") == "10 of 70 attempts"
            await page.screenshot(path=shot("results-suite-family"))
    finally:
        viewer.close()


# --- the live viewer ------------------------------------------------------------------------------------


async def test_live_viewer_counts_the_agents_calls_labels_locations_and_shows_the_tv(tmp_path: Path) -> None:
    import numpy as np
    from PIL import Image

    async with live_server(tmp_path / "memory", "--profile", "eval") as (client, url), browser_page() as page:
        await page.goto(url)
        await page.wait_for_function("document.body.dataset.ready === 'true'", timeout=90_000)
        await client.call_tool("begin_task", {"task_id": "T1"})
        for tool, arguments in (("look_around", {}), ("move_to", {"location": "Living Room TV"})):
            result = await client.call_tool(tool, arguments)
            assert not result.is_error, result.content
        await client.call_tool("check_task", {"task_id": "T1"})
        await page.wait_for_function("document.getElementById('map').dataset.location === 'Living Room TV'")
        await page.wait_for_function("document.getElementById('verdict').dataset.truth === 'false'")
        assert await page.text_content("#call-count") == "2"  # look_around and move_to: the agent's
        await page.reload()  # a page opened later counts the same
        await page.wait_for_function("document.body.dataset.ready === 'true'")
        assert await page.text_content("#call-count") == "2"
        await page.wait_for_function("document.getElementById('camera').naturalWidth === 320")
        await page.screenshot(path=shot("live-at-the-tv"))
        camera = await page.request.get(url + "api/camera.png")
        pixels = np.asarray(Image.open(io.BytesIO(await camera.body())).convert("L"))
        assert (pixels < 30).mean() < 0.01, "the camera shows a black void at the TV"
        await client.call_tool("move_to", {"location": "Front Door"})
        await page.wait_for_function("document.getElementById('map').dataset.location === 'Front Door'")
        await page.screenshot(path=shot("live-at-the-front-door"))
        robot = json.loads(await page.get_attribute("#map", "data-robot") or "{}")
        labels = json.loads(await page.get_attribute("#map", "data-labels") or "[]")
        assert {box["name"] for box in labels} >= {"Front Door", "Kitchen Shelf", "Living Room TV"}
        assert robot["label"] < robot["y"] - robot["r"], "the robot's own name is drawn over it"
        for box in labels:  # no name starts inside the circle the robot turns in
            nearest_x = min(max(robot["x"], box["x0"]), box["x1"])
            nearest_y = min(max(robot["y"], box["y0"]), box["y1"])
            assert (nearest_x - robot["x"]) ** 2 + (nearest_y - robot["y"]) ** 2 > robot["r"] ** 2, box
