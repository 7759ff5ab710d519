"""The live viewer as a browser sees it: a real `robocog-server --view` over stdio, driven by an MCP
client, watched by headless Chromium (Playwright).

- Update latency: the time from an MCP tool call returning to the page's DOM showing its result
  (the page stamps each result row with Date.now(); the same clock as this process), p50/p95 over
  `CALLS` read-only calls; and from a move_to returning to the robot drawn at its new place.
  Negative: the page had it before the client did (the result event leaves before the response).
- Memory: the page's JS heap (after a forced garbage collection, through the DevTools protocol)
  and its DOM size, before and after `MANY` tool calls: bounded, the page keeps at most 200 rows.

Skipped (with the reason in the figures) without Chromium or Playwright.
"""

from __future__ import annotations

import re
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, TextIO, cast

import anyio
from mcp import Client
from mcp.client.stdio import StdioServerParameters, stdio_client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.helpers import server_command

CALLS = 50
MOVES = 6
MANY = 1000


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return round(ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))], 1)


async def _heap(page: Any, cdp: Any) -> dict[str, float]:
    await cdp.send("HeapProfiler.collectGarbage")
    usage = await cdp.send("Runtime.getHeapUsage")
    nodes = await page.evaluate("document.getElementsByTagName('*').length")
    rows = await page.evaluate("document.querySelectorAll('#stream li').length")
    return {"heap_mb": round(usage["usedSize"] / 1e6, 2), "dom_nodes": nodes, "rows": rows}


async def _measure(executable: str) -> dict[str, Any]:
    from playwright.async_api import async_playwright

    command, *rest = server_command()
    with tempfile.TemporaryDirectory() as tmp, tempfile.NamedTemporaryFile("w+", suffix=".log") as log:
        args = [*rest, "--profile", "eval", "--view", "0", "--data-dir", str(Path(tmp) / "memory")]
        params = StdioServerParameters(command=command, args=args, env={"ANONYMIZED_TELEMETRY": "False"})
        async with Client(stdio_client(params, errlog=cast(TextIO, log))) as client, async_playwright() as pw:
            url = None
            with anyio.fail_after(60):
                while url is None:
                    found = re.search(r"live viewer at (http://\S+/)", Path(log.name).read_text())
                    url = found.group(1) if found else None
                    await anyio.sleep(0.05)
            browser = await pw.chromium.launch(executable_path=executable, headless=True, args=["--no-sandbox"])
            page = await browser.new_page(viewport={"width": 1280, "height": 800})
            await page.goto(url)
            await page.wait_for_function("document.body.dataset.ready === 'true'", timeout=60_000)
            cdp = await page.context.new_cdp_session(page)

            base = await page.evaluate("window.robocog.resultTimes.length")
            returned: list[float] = []
            for _ in range(CALLS):
                await client.call_tool("view_scratchpad", {})
                returned.append(time.time() * 1000)
                await page.wait_for_function(f"window.robocog.resultTimes.length >= {base + len(returned)}")
            shown = await page.evaluate(f"window.robocog.resultTimes.slice({base}, {base + CALLS})")
            latency = [s - r for s, r in zip(shown, returned, strict=True)]

            moved: list[float] = []
            for i in range(MOVES):
                target = ("Kitchen Door", "Hallway Area Door")[i % 2]
                await client.call_tool("move_to", {"location": target})
                done = time.time() * 1000
                await page.wait_for_function(f"document.getElementById('map').dataset.location === {target!r}")
                moved.append(await page.evaluate("window.robocog.stateTimes.at(-1)") - done)

            before = await _heap(page, cdp)
            for _ in range(MANY):
                await client.call_tool("view_scratchpad", {})
            total = base + CALLS + MOVES + MANY
            await page.wait_for_function(f"window.robocog.calls >= {total}", timeout=60_000)
            after = await _heap(page, cdp)
            await browser.close()
    return {
        "viewer.update_latency_ms_p50": _pct(latency, 0.5),
        "viewer.update_latency_ms_p95": _pct(latency, 0.95),
        "viewer.update_latency_calls": CALLS,
        "viewer.move_shown_after_ms_p50": round(statistics.median(moved), 1),
        "viewer.move_shown_after_ms_max": round(max(moved), 1),
        "viewer.page_heap_mb_before": before["heap_mb"],
        "viewer.page_heap_mb_after_1000_calls": after["heap_mb"],
        "viewer.page_dom_nodes_before": before["dom_nodes"],
        "viewer.page_dom_nodes_after_1000_calls": after["dom_nodes"],
        "viewer.page_rows_after_1000_calls": after["rows"],
    }


def run() -> dict[str, Any]:
    executable = shutil.which("chromium") or shutil.which("chromium-browser")
    if executable is None:
        return {"viewer.skipped": "no Chromium (apt-get install chromium)"}
    try:
        import playwright.async_api  # noqa: F401
    except ImportError:
        return {"viewer.skipped": "no Playwright (pip install -e '.[browser]')"}
    return anyio.run(_measure, executable)


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
