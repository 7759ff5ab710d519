"""The docs site opened from disk (file://), as someone who unpacked it reads it: search finds pages
(the index as a script, the search worker in an iframe: docs/javascripts/iframe-worker.js), nothing is
fetched from the network, and the figures page folds what is long."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.browser import browser_page
from tests.helpers import ROOT

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent))
    if mkdocs is None:
        pytest.skip("the docs extra is not installed (make docs installs it)")
    if not (ROOT / "build" / "typecheck" / "robocog").exists():
        pytest.skip("the API pages need build/typecheck (make docs lays it out)")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    subprocess.run(
        [mkdocs, "build", "--strict", "--quiet", "--site-dir", str(out)], cwd=ROOT, env=env, check=True, timeout=600
    )
    return out


async def test_search_works_from_disk_and_nothing_is_fetched(site: Path) -> None:
    async with browser_page() as page:
        fetched: list[str] = []
        problems: list[str] = []
        page.on(
            "request", lambda r: fetched.append(r.url) if not r.url.startswith(("file:", "data:", "about:")) else None
        )
        page.on("pageerror", lambda e: problems.append(str(e)))
        await page.goto((site / "index.html").as_uri())
        search = page.locator("input[data-md-component=search-query]")
        await search.wait_for(state="visible")  # Material shows it once its search worker is ready
        await search.click()
        await page.keyboard.type("scratchpad", delay=30)
        first = page.locator(".md-search-result__item").first
        await first.wait_for(state="visible", timeout=30_000)
        assert await page.locator(".md-search-result__item").count() >= 3
        assert fetched == [] and problems == [], (fetched, problems)


async def test_the_figures_page_folds_its_long_parts(site: Path) -> None:
    async with browser_page() as page:
        await page.goto((site / "figures.html").as_uri())
        folded = await page.locator("details:not([open])").count()
        assert folded >= 10  # the table of every figure, a fold per bench, and the rounds' history
        height = await page.evaluate("document.documentElement.scrollHeight")
        assert height < 30_000, height  # it was 47,387 px
