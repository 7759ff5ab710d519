"""A robot belongs to one client, whatever protocol generation it speaks: two default SDK clients
(`mcp.Client(url)`, sessionless MCP 2026-07-28) over real HTTP that send back the handle the server
minted them (here in `_meta["robocog/driver"]`, the alias robocog's own client uses; tests/e2e/
test_any_client.py passes it as `robot_id`) get robots of their own on a fleet, and on one robot the
second is refused until the first lets go; a handle cannot be made up, and a watcher's read-only
calls are not the driver's. Real server processes on loopback."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp_types import CallToolResult

from robocog.shared.protocol import DRIVER_META_KEY
from tests.helpers import http_server

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def fleet_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("fleet")
    with http_server(tmp / "server.log", "--profile", "eval", "--robots", "2", "--data-dir", str(tmp / "m")) as url:
        yield url


@pytest.fixture(scope="module")
def robot_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    tmp = tmp_path_factory.mktemp("one")
    with http_server(tmp / "server.log", "--data-dir", str(tmp / "m")) as url:
        yield url


def text(result: CallToolResult) -> str:
    return " ".join(getattr(c, "text", "") for c in result.content)


class Driver:
    """A default SDK client that keeps the driver id the server issued it and sends it back."""

    def __init__(self, client: Client) -> None:
        self.client = client
        self.meta: dict[str, Any] | None = None

    async def call(self, tool: str, **arguments: Any) -> CallToolResult:
        result = await self.client.call_tool(tool, arguments, meta=self.meta)  # type: ignore[arg-type]
        issued = (result.meta or {}).get(DRIVER_META_KEY)
        if issued is not None:
            assert self.meta is None, "an id is issued once, to a call that sent none"
            self.meta = {DRIVER_META_KEY: issued}
        return result

    async def ok(self, tool: str, **arguments: Any) -> dict[str, Any]:
        result = await self.call(tool, **arguments)
        assert not result.is_error, text(result)
        assert isinstance(result.structured_content, dict)
        return result.structured_content


async def test_two_default_sdk_clients_get_robots_of_their_own_on_a_fleet(fleet_url: str) -> None:
    async with Client(fleet_url) as one, Client(fleet_url) as two:
        a, b = Driver(one), Driver(two)
        await a.ok("look_around")  # an id-less read-only call mints a handle and binds a robot to it
        await b.ok("look_around")
        await a.ok("add_to_scratchpad", text="a's secret plan")
        assert a.meta and b.meta and a.meta != b.meta, "each got an id of its own"
        await a.ok("move_to", location="Kitchen Door")
        pad = await b.ok("view_scratchpad")
        assert "a's secret plan" not in json.dumps(pad), "b reads its own scratchpad"
        assert (await b.ok("look_around"))["location"] == "Front Door", "a did not move b's robot"
        assert (await a.ok("look_around"))["location"] == "Kitchen Door"
        # b cannot pose as a by making an id up, nor by changing one character of a real one
        real = str(a.meta[DRIVER_META_KEY])
        for fake in ("a", real[:-1] + ("0" if real[-1] != "0" else "1")):
            refused = await two.call_tool("move_to", {"location": "Living Room Door"}, meta={DRIVER_META_KEY: fake})  # type: ignore[arg-type]
            assert refused.is_error and "not a robot handle this server minted" in text(refused)
        assert (await a.ok("look_around"))["location"] == "Kitchen Door"
        # a resource read without an id has no robot on a fleet: told what to send
        with pytest.raises(Exception, match="robot_id"):
            await two.read_resource("robocog://world/state")


async def test_on_one_robot_the_second_default_client_is_refused_until_the_first_lets_go(robot_url: str) -> None:
    async with Client(robot_url) as one, Client(robot_url) as two:
        a, b = Driver(one), Driver(two)
        await a.ok("move_to", location="Hallway Area Door")  # the anonymous driver takes it; a handle is minted
        await a.ok("move_to", location="Kitchen Door")  # a presents its handle: from now on the handle holds
        refused = await b.call("move_to", location="Living Room Door")
        assert refused.is_error and "passes robot_id" in text(refused), text(refused)
        # b watches: its read-only calls work and are not counted in a's episode
        for _ in range(5):
            assert (await b.ok("look_around"))["location"] == "Kitchen Door"
        ended = await a.ok("end_task", status="success", description="walk", summary="walked to the kitchen door")
        assert ended["tool_calls"] == 3, "a's two moves and its end_task; none of b's looks"
        # a claims nothing more; b is still refused while a's lease runs (600 s after a's last call)
        assert (await b.call("add_to_scratchpad", text="b")).is_error


def test_the_contract_publishes_the_rule_and_the_checker_sees_it_go() -> None:
    from robocog.agent.contract.diff import compare_contracts
    from robocog.shared.protocol import CONTRACT_VERSION
    from tests.helpers import CONTRACT_DIR

    live = json.loads((CONTRACT_DIR / "default.json").read_text(encoding="utf-8"))
    assert CONTRACT_VERSION.split(".")[0] == "4"
    assert {"experimental.robocog/driver.issued", "experimental.robocog/driver.handle"} <= set(live["capabilities"])
    without = live | {"capabilities": [c for c in live["capabilities"] if not c.startswith("experimental")]}
    rule = "capability experimental.robocog/driver.issued"
    dropped = compare_contracts(live, without)
    assert {c.kind for c in dropped if c.where == rule} == {"breaking"}
    # and against the 2.x files, which did not hold it, the rule arriving is the break 3.0 is numbered for
    added = compare_contracts(without, live)
    assert {c.kind for c in added if c.where == rule} == {"breaking"}
    # as the handle rule arriving is the break 4.0 is numbered for
    assert {c.kind for c in added if c.where == "capability experimental.robocog/driver.handle"} == {"breaking"}
    assert {c.kind for c in added if c.where == "capability experimental.robocog/driver"} == {"compatible"}


async def test_the_second_client_drives_once_the_first_lets_go(tmp_path: Path) -> None:
    import anyio

    with http_server(tmp_path / "server.log", "--session-idle-s", "2", "--data-dir", str(tmp_path / "m")) as url:
        async with Client(url) as one, Client(url) as two:
            a, b = Driver(one), Driver(two)
            await a.ok("move_to", location="Hallway Area Door")
            await a.ok("move_to", location="Kitchen Door")  # a sent its handle back: its lease runs 2 s
            assert (await b.call("move_to", location="Living Room Door")).is_error
            await anyio.sleep(2.5)  # a is silent past --session-idle-s: it has let go
            assert (await b.ok("move_to", location="Hallway Area Door"))["location"] == "Hallway Area Door"
            await b.ok("move_to", location="Kitchen Door")  # b presents the handle it was minted
            refused = await a.call("move_to", location="Kitchen Door")
            assert refused.is_error and "driven by a client that passes robot_id" in text(refused), "now a is refused"
