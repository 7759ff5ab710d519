"""What the browser tests share: Debian's Chromium driven by Playwright (or a skip that says how to
get them), a page, an ASGI app served on a free loopback port, and where screenshots go
(build/screenshots, opened by hand). A real `robocog-server --view 0` and the address its viewer
announced: `tests.helpers.live_server`."""

from __future__ import annotations

import shutil
import socket
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import pytest

from tests.helpers import ROOT

SCREENSHOTS = ROOT / "build" / "screenshots"
INSTALL = (
    "the browser tests need Chromium and Playwright: `apt-get install chromium` (as root; `make test` does it) "
    "and `pip install -e '.[browser]'`"
)


def chromium() -> str:
    """The system Chromium, or skip the test saying how to install it."""
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.skip(f"no Chromium: {INSTALL}")
    try:
        import playwright.async_api  # noqa: F401
    except ImportError:
        pytest.skip(f"no Playwright: {INSTALL}")
    return path


def screenshot_path(name: str) -> Path:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    return SCREENSHOTS / name


@asynccontextmanager
async def browser_page(width: int = 1280, height: int = 800) -> AsyncIterator[Any]:
    """A page of a headless Chromium of that viewport."""
    executable = chromium()
    from playwright.async_api import async_playwright

    async with async_playwright() as pw:
        browser = await pw.chromium.launch(executable_path=executable, headless=True, args=["--no-sandbox"])
        try:
            yield await browser.new_page(viewport={"width": width, "height": height})
        finally:
            await browser.close()


@asynccontextmanager
async def serving(app: Any) -> AsyncIterator[str]:
    """`app` served by uvicorn on a free loopback port, for the test's duration."""
    import uvicorn

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    sock.setblocking(False)
    server = uvicorn.Server(uvicorn.Config(app, log_config=None, log_level="warning", lifespan="off"))
    async with anyio.create_task_group() as tg:
        tg.start_soon(lambda: server.serve(sockets=[sock]))
        while not server.started:
            await anyio.sleep(0.02)
        try:
            yield f"http://127.0.0.1:{sock.getsockname()[1]}/"
        finally:
            server.should_exit = True
    sock.close()
