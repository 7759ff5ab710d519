"""The robot app (an MCP App, SEP-1865) as a plain MCP client sees it: the official SDK's default
client, with no robocog code on its side, against a real `robocog-server` process over stdio. It lists
`ui://robocog/robot` (`text/html;profile=mcp-app`, CSP metadata with no origin), the robot tools name
it in `_meta.ui.resourceUri` with their text content as before, `robot_view` is for the app alone; with
`--no-app` none of it is there. The MCP Inspector's CLI sees the same over HTTP. The page itself in
Chromium: tests/e2e/test_robot_app_browser.py."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp_types import TextResourceContents

from tests.helpers import APP_TOOLS, ROBOT_TOOLS, http_server, stdio_params
from tests.inspector_cli import inspector

pytestmark = pytest.mark.anyio

#: The MCP Inspector's CLI, installed by `make inspector-cli` (`make test` does it where Node.js is).
URI = "ui://robocog/robot"
MIME = "text/html;profile=mcp-app"
LINKED = {"look_around", "move_to", "grab", "place", "open", "close", "look", "end_task"}
NO_NETWORK: dict[str, list[str]] = {
    "connectDomains": [],
    "resourceDomains": [],
    "frameDomains": [],
    "baseUriDomains": [],
}


def ui(meta: dict[str, Any] | None) -> Any:
    return (meta or {}).get("ui")


async def test_a_plain_client_lists_the_app_and_the_tools_that_name_it(tmp_path: Path) -> None:
    async with Client(stdio_params("--data-dir", str(tmp_path))) as client:
        resources = {str(r.uri): r for r in (await client.list_resources()).resources}
        assert resources[URI].mime_type == MIME
        assert ui(resources[URI].meta) == {"csp": NO_NETWORK, "prefersBorder": True}
        tools = {t.name: t for t in (await client.list_tools()).tools}
        assert set(tools) == ROBOT_TOOLS | APP_TOOLS
        linked = {name for name, t in tools.items() if (ui(t.meta) or {}).get("resourceUri") == URI}
        assert linked == LINKED | APP_TOOLS
        assert all("visibility" not in ui(tools[name].meta) for name in LINKED), "the model sees the robot tools"
        assert ui(tools["robot_view"].meta)["visibility"] == ["app"], "robot_view is the app's alone"
        assert all(ui(tools[name].meta) is None for name in ROBOT_TOOLS - LINKED)

        read = await client.read_resource(URI)
        [page] = read.contents
        assert isinstance(page, TextResourceContents) and page.mime_type == MIME
        assert ui(page.meta) == {"csp": NO_NETWORK, "prefersBorder": True}, "hosts read the CSP from the content"
        assert page.text.startswith("<!doctype html>") and "Kitchen" not in page.text, "no data in the HTML"
        for remote in ("http://", "https://", "//cdn", ' src="http'):
            assert f'src="{remote}' not in page.text and f'href="{remote}' not in page.text

        moved = await client.call_tool("move_to", {"location": "Kitchen Table"})
        assert not moved.is_error and isinstance(moved.structured_content, dict)
        [text] = [c for c in moved.content if c.type == "text"]
        assert json.loads(text.text) == moved.structured_content, "the text content is the whole result, as before"

        view = await client.call_tool("robot_view", {"camera_frame": True})
        data = view.structured_content
        assert not view.is_error and isinstance(data, dict)
        assert data["world"]["robot"]["location"] == "Kitchen Table"
        assert {loc["name"] for loc in data["scene"]["locations"]} >= {"Kitchen Shelf", "Front Door"}
        assert data["task_id"] is None and data["verdict"] is None, "no task is known yet"
        assert [c.type for c in view.content] == ["text", "image"], "the camera's picture when asked"
        assert data["tool_calls"] == 1, "the app's reads are not the episode's calls"


async def test_no_app_publishes_no_app(tmp_path: Path) -> None:
    async with Client(stdio_params("--no-app", "--data-dir", str(tmp_path))) as client:
        resources = [str(r.uri) for r in (await client.list_resources()).resources]
        assert resources and not [uri for uri in resources if uri.startswith("ui://")]
        tools = (await client.list_tools()).tools
        assert {t.name for t in tools} == ROBOT_TOOLS
        assert [t.name for t in tools if t.meta and "ui" in t.meta] == []


def test_the_mcp_inspector_lists_the_app_and_the_tools_that_name_it(tmp_path: Path) -> None:
    with http_server(tmp_path / "server.log", "--data-dir", str(tmp_path / "m")) as url:
        resources = {r["uri"]: r for r in inspector(url, "resources/list")["resources"]}
        tools = {t["name"]: t for t in inspector(url, "tools/list")["tools"]}
    assert resources[URI]["mimeType"] == MIME and ui(resources[URI].get("_meta"))["csp"] == NO_NETWORK
    assert {name for name, t in tools.items() if (ui(t.get("_meta")) or {}).get("resourceUri") == URI} >= LINKED
