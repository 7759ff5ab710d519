"""The robot app: an MCP App (SEP-1865) that shows the robot inside the chat.

One page, `ui://robocog/robot` (`text/html;profile=mcp-app`), built from `assets/app/src/` into one
self-contained file (`assets/app/robot.html`: ext-apps' `App`, the live viewer's map renderer, no
network). The robot tools name it in `_meta.ui.resourceUri`; a host that renders apps shows it in a
sandboxed iframe and hands it the tools' results, whose structured content it draws (the data never
goes into the HTML). It refreshes through `robot_view`, a read-only tool for the app alone
(`_meta.ui.visibility: ["app"]`). `robocog-server --no-app` publishes none of it.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Any

from robocog.assets import ASSETS_DIR
from robocog.shared.protocol import APP_MIME_TYPE, APP_URI

if TYPE_CHECKING:
    from mcp.server.mcpserver import MCPServer

    from robocog.server.state import AppState

#: The built page (`make app` rebuilds it from `assets/app/src/`).
APP_PAGE = ASSETS_DIR / "app" / "robot.html"
#: The robot tools whose results the app draws.
LINKED_TOOLS = frozenset({"look_around", "move_to", "grab", "place", "open", "close", "look", "end_task"})
#: The page loads nothing from the network: no origins for fetch, scripts, styles, images or frames.
RESOURCE_META: dict[str, Any] = {
    "ui": {
        "csp": {"connectDomains": [], "resourceDomains": [], "frameDomains": [], "baseUriDomains": []},
        "prefersBorder": True,
    }
}


def tool_meta(name: str, kind: str) -> dict[str, Any] | None:
    """The `_meta` of tool `name` (of `kind`, `Tool.kind`) when the app is on: the page for a linked
    robot tool; the page and the app-only visibility for the app's own tools; None for the rest."""
    if kind == "app":
        return {"ui": {"resourceUri": APP_URI, "visibility": ["app"]}}
    if name in LINKED_TOOLS:
        return {"ui": {"resourceUri": APP_URI}}
    return None


@cache
def page() -> str:
    """The app's HTML, as shipped."""
    return APP_PAGE.read_text(encoding="utf-8")


def register_app(mcp: MCPServer[AppState]) -> None:
    """Publish the app's page as a resource (its CSP metadata on the listing and on the content)."""

    @mcp.resource(
        APP_URI,
        name="robot_app",
        title="The robot, inside the chat",
        description="An MCP App: the map of the house with the robot, its path and what it holds, the furniture "
        "open or closed, the camera, the last tool calls and the ground truth. Self-contained: it loads nothing "
        "from the network.",
        mime_type=APP_MIME_TYPE,
        meta=RESOURCE_META,
    )
    def robot_app() -> str:
        return page()
