"""The robot app (`ui://robocog/robot`, an MCP App): its page's size, how soon a tool result a host
hands it is on the map, and what it costs the server.

- Page: bytes of `assets/app/robot.html` as shipped and gzipped (a host fetches it once per chat).
- Repaint: in the test host of tests/app_host (ext-apps' AppBridge in headless Chromium, the page
  in a sandboxed iframe), from the host posting a result of T1 to the page to the page's map drawn
  with the world after it (the page asks robot_view through the bridge, the host's client asks the
  server), each call made once the page has drawn the last (as in a chat, where the model thinks
  between calls): p50 and p90 over every call of `RUNS` T1 episodes (12 calls each).
- Server CPU per robot call: the server process's CPU (user + system, /proc) over T1 driven by the
  official SDK's client over HTTP (after a first look_around), divided by its 12 calls: with
  `--no-app` (the server as before the app), with the app published and no host showing it (what
  every client pays: the tools' `_meta`),
  and with the test host showing it (the page's robot_view reads, a camera picture after each move,
  count in the server's CPU too). `RUNS` fresh servers each.

Skipped (with the reason in the figures) without Chromium, Playwright, Node.js or `make app-deps`.
"""

from __future__ import annotations

import gzip
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

import anyio
from mcp import Client

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.helpers
from tests.app_host import host_script, missing, open_app, relay
from tests.helpers import ROOT, T1, T1_SEQUENCE, action_args, http_server_process

RUNS = 3
TICKS = os.sysconf("SC_CLK_TCK")
END = {"status": "success", "description": T1, "summary": "The cube, box and mug are on the shelf."}


def _cpu_s(pid: int) -> float:
    text = Path(f"/proc/{pid}/stat").read_text()
    fields = text[text.rindex(")") + 2 :].split()
    return sum(int(v) for v in fields[11:13]) / TICKS  # utime, stime


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return round(ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))], 1)


async def _episode(url: str, pid: int, script: str | None) -> tuple[float, list[float]]:
    """T1 and end_task on a fresh server: the server's CPU seconds over it, and the repaint lags."""
    async with Client(url) as client:
        await client.call_tool("look_around", {})  # warm: the first call's imports and schemas
        calls = [(a[0], action_args(a)) for a in T1_SEQUENCE[1:]] + [("end_task", END)]
        if script is None:
            before = _cpu_s(pid)
            for tool, arguments in calls:
                await client.call_tool(tool, arguments)
            return _cpu_s(pid) - before, []
        from playwright.async_api import async_playwright

        async with async_playwright() as pw:
            chromium = shutil.which("chromium") or shutil.which("chromium-browser")
            browser = await pw.chromium.launch(executable_path=chromium, headless=True, args=["--no-sandbox"])
            page = await browser.new_page(viewport={"width": 1120, "height": 640})
            frame = await open_app(page, client, script)
            before = _cpu_s(pid)
            for n, (tool, arguments) in enumerate(calls, start=1):
                await relay(page, client, tool, arguments)
                # paced as in a chat, where a model thinks between calls: the map is drawn before the next
                await frame.wait_for_function("n => robocogApp.paints.length >= n", arg=n, timeout=60_000)
            spent = _cpu_s(pid) - before
            relayed = await page.evaluate("() => robocogHost.relayed")
            paints = await frame.evaluate("() => robocogApp.paints")
            await browser.close()
            return spent, [p - r for p, r in zip(paints, relayed, strict=True)]


def _runs(args: list[str], script: str | None) -> tuple[list[float], list[float]]:
    per_call: list[float] = []
    lags: list[float] = []
    for _ in range(RUNS):
        with tempfile.TemporaryDirectory() as tmp:
            log = Path(tmp) / "server.log"
            with http_server_process(log, *args, "--data-dir", str(Path(tmp) / "m")) as (url, proc):
                spent, lag = anyio.run(_episode, url, proc.pid, script)
        per_call.append(spent * 1000 / len(T1_SEQUENCE))
        lags += lag
    return per_call, lags


def run() -> dict[str, Any]:
    page = (ROOT / "assets" / "app" / "robot.html").read_bytes()
    figures: dict[str, Any] = {"app.page_kb": round(len(page) / 1024, 1)}
    figures["app.page_gzip_kb"] = round(len(gzip.compress(page, 9)) / 1024, 1)
    plain, _ = _runs(["--no-app"], None)
    linked, _ = _runs([], None)
    figures["app.server_cpu_ms_per_call_no_app"] = round(statistics.median(plain), 2)
    figures["app.server_cpu_ms_per_call_app_unshown"] = round(statistics.median(linked), 2)
    why = missing()
    if shutil.which("chromium") is None and shutil.which("chromium-browser") is None:
        why = "no Chromium (apt-get install chromium)"
    if why is not None:
        figures["app.host_skipped"] = why
        return figures
    with tempfile.TemporaryDirectory() as tmp:
        script = host_script(Path(tmp) / "host.js")
    shown, lags = _runs([], script)
    figures["app.server_cpu_ms_per_call_app_shown"] = round(statistics.median(shown), 2)
    figures["app.repaint_ms_p50"] = _pct(lags, 0.5)
    figures["app.repaint_ms_p90"] = _pct(lags, 0.9)
    figures["app.repaint_samples"] = len(lags)
    return figures
