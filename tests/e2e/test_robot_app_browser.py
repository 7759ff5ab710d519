"""The robot app in Chromium, in a host built from ext-apps' AppBridge (tests/app_host/host.js): the
host reads `ui://robocog/robot` from a real `robocog-server` process with the official SDK's default
client, renders it in a sandboxed iframe under the CSP its metadata asks for, and relays the results
of T1, which the same client drives; the page's own reads (robot_view) go through the bridge to that
client. A scene whose object's name holds HTML shows it as text, and no script of its runs.
Screenshots: build/screenshots/robot_app_*.png (opened by hand)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest
import yaml
from mcp import Client

from robocog.assets import ASSETS_DIR
from tests.app_host import host_script as build_host
from tests.app_host import missing, open_app, relay
from tests.browser import browser_page, screenshot_path
from tests.helpers import T1, T1_SEQUENCE, action_args, http_server

pytestmark = pytest.mark.anyio

HTML_NAME = '<img src=x onerror="document.body.dataset.pwned=1">'


@pytest.fixture(scope="module")
def host_script(tmp_path_factory: pytest.TempPathFactory) -> str:
    """The test host's script, bundled from tests/app_host/host.js with the pinned esbuild (offline)."""
    why = missing()
    if why is not None:
        pytest.skip(why)
    return build_host(tmp_path_factory.mktemp("host") / "host.js")


@pytest.fixture
def server(tmp_path: Path) -> Iterator[str]:
    with http_server(tmp_path / "server.log", "--data-dir", str(tmp_path / "m")) as url:
        yield url


async def test_the_app_shows_t1_as_a_host_relays_it(server: str, host_script: str) -> None:
    async with Client(server) as client, browser_page(1120, 640) as page:
        frame = await open_app(page, client, host_script)
        for action in T1_SEQUENCE:
            result = await relay(page, client, action[0], action_args(action))
            assert not result.is_error, result.content
        await relay(page, client, "look", {"direction": "Kitchen Shelf"})
        summary = "Put the cube, box and mug on the shelf's three layers."
        await relay(page, client, "end_task", {"status": "success", "description": T1, "summary": summary})
        await frame.wait_for_selector("#verdict[data-truth=true]", timeout=30_000)
        await frame.wait_for_function("() => robocogApp.paints.length >= robocogApp.results.length", timeout=30_000)
        await anyio.sleep(0.3)  # the camera's picture decodes
        await page.screenshot(path=str(screenshot_path("robot_app_t1.png")))

        assert await frame.get_attribute("#map", "data-location") == "Kitchen Shelf"
        assert await frame.get_attribute("#verdict", "data-task") == "T1"
        assert await frame.text_content("#robot-holding") == "nothing"
        on_shelf = json.loads(await frame.get_attribute("#map", "data-furniture") or "[]")
        assert on_shelf == [], "the paper's household has no furniture that opens"
        view = await frame.evaluate("() => ({world: window.robocogApp.world, calls: window.robocogApp.calls})")
        layers = {o["object"]: o["position"] for o in view["world"]["objects"] if o["location"] == "Kitchen Shelf"}
        assert layers == {"cube": "top", "box": "middle", "mug": "bottom"}
        assert view["calls"] == len(T1_SEQUENCE) + 2
        tools = await frame.eval_on_selector_all("#calls li", "items => items.map(li => li.dataset.tool)")
        assert tools[:3] == ["end_task", "look", "place"] and tools[-1] == "look_around"
        assert (await frame.get_attribute("#camera", "src") or "").startswith("data:image/png;base64,")
        caption = await frame.text_content("#camera-caption")
        assert caption == "what the agent saw: looking toward Kitchen Shelf from Kitchen Shelf", caption
        host = await page.evaluate("() => ({calls: robocogHost.calls, relayed: robocogHost.relayed})")
        assert set(host["calls"]) == {"robot_view"}, "the page reads through the bridge, and only robot_view"
        times = await frame.evaluate("() => ({results: robocogApp.results, paints: robocogApp.paints})")
        lags = [p - r for p, r in zip(times["paints"], host["relayed"], strict=False)]
        assert len(lags) == len(T1_SEQUENCE) + 2 and all(0 <= lag < 10_000 for lag in lags)
        print(f"tool result to repaint: median {sorted(lags)[len(lags) // 2]:.1f} ms, max {max(lags):.1f} ms")


async def test_a_name_holding_html_shows_as_text_and_runs_nothing(tmp_path: Path, host_script: str) -> None:
    scene = yaml.safe_load((ASSETS_DIR / "scenes" / "household.yaml").read_text(encoding="utf-8"))
    scene["objects"][0]["name"] = HTML_NAME  # the cube, at the Front Door where the robot starts
    path = tmp_path / "house.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False), encoding="utf-8")
    with http_server(tmp_path / "server.log", "--scene", str(path), "--data-dir", str(tmp_path / "m")) as url:
        async with Client(url) as client, browser_page(1120, 640) as page:
            frame = await open_app(page, client, host_script)
            await relay(page, client, "look_around", {})
            grabbed = await relay(page, client, "grab", {"object": HTML_NAME})
            assert not grabbed.is_error, grabbed.content
            await frame.wait_for_function("() => robocogApp.paints.length >= 2", timeout=30_000)
            assert (await frame.text_content("#camera-caption") or "").startswith("live, looking ahead from")
            await page.screenshot(path=str(screenshot_path("robot_app_html_name.png")))

            assert await frame.text_content("#robot-holding") == HTML_NAME, "the name, as text"
            assert HTML_NAME in (await frame.text_content("#calls") or "")
            assert await frame.eval_on_selector_all("img", "imgs => imgs.map(i => i.id)") == ["camera"]
            assert await frame.evaluate("() => document.body.dataset.pwned") is None, "no script of the name ran"


async def test_the_app_shows_furniture_open_and_closed(tmp_path: Path, host_script: str) -> None:
    with http_server(tmp_path / "server.log", "--scene", "kitchen_plus", "--data-dir", str(tmp_path / "m")) as url:
        async with Client(url) as client, browser_page(1120, 640) as page:
            frame = await open_app(page, client, host_script)
            states = "() => JSON.parse(document.getElementById('map').dataset.furniture).map(f => f[0] + ':' + f[1])"
            assert set(await frame.evaluate(states)) == {
                "kitchen_drawer:closed",
                "kitchen_cabinet:closed",
                "fridge:closed",
            }
            for tool, arguments in [("move_to", {"location": "Fridge"}), ("open", {"furniture": "fridge"})]:
                result = await relay(page, client, tool, arguments)
                assert not result.is_error, result.content
            await frame.wait_for_function("() => robocogApp.paints.length >= 2", timeout=30_000)
            await page.screenshot(path=str(screenshot_path("robot_app_fridge_open.png")))
            assert "fridge:open" in await frame.evaluate(states)
            assert "kitchen_drawer:closed" in await frame.evaluate(states)
            tools = await frame.eval_on_selector_all("#calls li", "items => items.map(li => li.dataset.tool)")
            assert tools == ["open", "move_to"]


async def test_the_app_shows_the_robot_its_calls_act_on_in_a_fleet(tmp_path: Path, host_script: str) -> None:
    """On a fleet, each handle has its own robot: the page asks about the one whose calls it is given."""
    args = ("--robots", "3", "--data-dir", str(tmp_path / "m"))
    with http_server(tmp_path / "server.log", *args) as url:
        async with Client(url) as mine, Client(url) as theirs, browser_page(1120, 640) as page:
            other = (await theirs.call_tool("look_around", {})).structured_content
            assert isinstance(other, dict) and other["robot_id"]
            moved = await theirs.call_tool("move_to", {"location": "Living Room", "robot_id": other["robot_id"]})
            assert not moved.is_error, moved.content
            first = await mine.call_tool("look_around", {})
            assert isinstance(first.structured_content, dict)
            handle = first.structured_content["robot_id"]
            assert handle and handle != other["robot_id"]
            frame = await open_app(page, mine, host_script, first=("look_around", {}, first))
            await relay(page, mine, "move_to", {"location": "Kitchen Table", "robot_id": handle})
            await frame.wait_for_function("() => robocogApp.paints.length >= 2", timeout=30_000)
            assert await frame.get_attribute("#map", "data-location") == "Kitchen Table"
            assert await frame.evaluate("() => robocogApp.robotId") == handle
