"""A test host for the robot app (`ui://robocog/robot`), built from ext-apps' AppBridge (`host.js`
here, bundled with the pinned esbuild by `assets/app/build.mjs --host`): it reads the app's resource
with the official MCP SDK's client, renders it in a sandboxed iframe of a Chromium page under the CSP
its metadata asks for, relays tool inputs and results to it, and answers the page's tool calls with
the same client. Used by tests/e2e/test_robot_app_browser.py and tests/bench/bench_app.py."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

from mcp import Client
from mcp_types import CallToolResult, TextResourceContents

ROOT = Path(__file__).resolve().parents[2]
MODULES = ROOT / ".cache" / "app" / "node_modules"
URI = "ui://robocog/robot"


def missing() -> str | None:
    """Why the host cannot be built here (no Node.js, or `make app-deps` not run), or None."""
    if shutil.which("node") is None:
        return "node is missing: the robot app's host page is bundled with Node.js"
    if not (MODULES / "esbuild").is_dir():
        return "the robot app's build tools are not installed: `make app-deps` (make test does it)"
    return None


def host_script(out: Path) -> str:
    """The host's script, bundled into `out` (offline: the packages are installed already)."""
    node = shutil.which("node")
    assert node is not None, missing()
    build = [node, str(ROOT / "assets" / "app" / "build.mjs"), "--host", str(out)]
    done = subprocess.run(build, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return out.read_text(encoding="utf-8")


def host_page(script: str) -> str:
    style = "body{margin:0;background:#eee}#app{width:1100px;height:620px;border:0;background:#fff}"
    head = f"<!doctype html><html><head><style>{style}</style></head>"
    return f'{head}<body><div id="slot"></div><script>{script}</script></body></html>'


def wire(result: CallToolResult) -> dict[str, Any]:
    """A tool result as it travels over MCP (camelCase, no nulls): what a host hands the page."""
    return result.model_dump(mode="json", by_alias=True, exclude_none=True)


async def open_app(
    page: Any, client: Client, script: str, first: tuple[str, dict[str, Any], CallToolResult] | None = None
) -> Any:
    """Load the app from the server into the host's sandboxed iframe and, as a host does for the call
    it opened the page for, hand it `first` (that call's tool, input and result); the page's frame,
    once it has drawn the world."""

    async def call_tool(params: str) -> str:
        asked = json.loads(params)
        return json.dumps(wire(await client.call_tool(asked["name"], asked.get("arguments") or {})))

    read = await client.read_resource(URI)
    [resource] = read.contents
    assert isinstance(resource, TextResourceContents)
    await page.expose_function("hostCallTool", call_tool)
    await page.set_content(host_page(script))
    await page.evaluate("([html, meta]) => robocogHost.load(html, meta)", [resource.text, resource.meta])
    if first is not None:
        _, arguments, result = first
        await page.evaluate("([i, r]) => robocogHost.relay(i, r)", [arguments, wire(result)])
    await page.frame_locator("#app").locator("body[data-ready=true]").wait_for(timeout=30_000)
    return page.frames[1]


async def relay(page: Any, client: Client, tool: str, arguments: dict[str, Any]) -> CallToolResult:
    """Call `tool` with the client, then hand its input and result to the page as a host does."""
    result = await client.call_tool(tool, arguments)
    await page.evaluate("([i, r]) => robocogHost.relay(i, r)", [arguments, wire(result)])
    return result
