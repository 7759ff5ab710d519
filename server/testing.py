"""A pytest plugin for people who build agents or MCP clients against the robot (entry point `pytest11`).

Installing robocog registers it; a test then asks for the fixtures by name:

    async def test_my_agent_puts_things_away(robocog_client, robocog_world):
        await my_agent.run(robocog_client, "Put away all the items into the shelf.")
        await robocog_world.assert_task("T1")

- `robocog_server`: an in-memory robocog server in the eval profile, seeded (`robocog_seed`, 0), with
  a temporary memory under the test's `tmp_path`; a fresh one per test.
- `robocog_client`: an `mcp.Client` connected to it (no process, no port).
- `robocog_world`: `RobocogWorld`, helpers on that client: `reset()`, `begin_task()`, `check_task()`,
  `assert_task()` (fails with the ground truth's reason per object), `state()`.

The fixtures are async (anyio): a coroutine test that uses them is marked `anyio` automatically,
unless it already carries an `anyio` or `asyncio` mark. Override `robocog_seed`, `robocog_profile`
or `robocog_config` in a conftest to change the world. `-p no:robocog` turns the plugin off.

The server modules are imported only when a fixture is used, so the plugin costs nothing otherwise.
"""

from __future__ import annotations

import inspect
import json
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import pytest

from robocog.shared.controls import EvalControls, mcp_call

if TYPE_CHECKING:
    from mcp import Client
    from mcp.server.mcpserver import MCPServer

    from robocog.server.config import SessionConfig
    from robocog.server.state import AppState

_FIXTURES = frozenset({"robocog_client", "robocog_world"})


class RobocogTaskFailed(AssertionError):
    """A task's ground truth does not hold; the message has the verdict's reason per object."""


@dataclass
class RobocogWorld:
    """Harness controls of the eval profile, through the MCP client (what a client author needs)."""

    client: Client

    @property
    def controls(self) -> EvalControls:
        """The eval controls, typed (`robocog.shared.controls`)."""
        return EvalControls(mcp_call(self.client))

    async def reset(self, seed: int | None = 0, *, randomize: bool = False) -> dict[str, Any]:
        """The start state again (a new episode); returns the world state."""
        return await self.controls.reset_world(seed=seed, randomize=randomize)

    async def begin_task(self, task_id: str, *, keep_scratchpad: bool = False) -> dict[str, Any]:
        """A new episode for `task_id`: the world as it is now is what check_task judges against."""
        return await self.controls.begin_task(task_id, keep_scratchpad=keep_scratchpad)

    async def check_task(self, task_id: str) -> dict[str, Any]:
        """The ground-truth verdict: `success`, `reason`, and `objects` with a reason each."""
        return (await self.controls.check_task(task_id)).model_dump()

    async def assert_task(self, task_id: str) -> dict[str, Any]:
        """Fail the test unless `task_id` truly succeeded; returns the verdict."""
        verdict = await self.check_task(task_id)
        if not verdict.get("success"):
            details = "; ".join(
                f"{o.get('object')}: {o.get('reason')}" for o in verdict.get("objects", []) if not o.get("ok", False)
            )
            raise RobocogTaskFailed(f"{task_id} failed: {verdict.get('reason')}" + (f" ({details})" if details else ""))
        return verdict

    async def state(self) -> dict[str, Any]:
        """Ground truth as the robocog://world/state resource gives it."""
        result = await self.client.read_resource("robocog://world/state")
        parsed: dict[str, Any] = json.loads(getattr(result.contents[0], "text", "{}"))
        return parsed


@pytest.fixture
def robocog_seed() -> int:
    """The seed of the world's random generator (override to change it)."""
    return 0


@pytest.fixture
def robocog_profile() -> Literal["default", "eval"]:
    """`eval` (the harness controls are published, so robocog_world works); override with `default`."""
    return "eval"


@pytest.fixture
def robocog_config(tmp_path: Path, robocog_seed: int) -> SessionConfig:
    """The session's configuration: seeded, memory in a temporary directory."""
    from robocog.server.config import SessionConfig

    return SessionConfig(seed=robocog_seed, data_dir=tmp_path / "robocog-memory")


@pytest.fixture
def robocog_server(robocog_config: SessionConfig, robocog_profile: Literal["default", "eval"]) -> MCPServer[AppState]:
    """An in-memory robocog server (not started: a client connecting to it starts it)."""
    from robocog.server.app import build_server

    return build_server(robocog_config, profile=robocog_profile)


@pytest.fixture
async def robocog_client(robocog_server: MCPServer[AppState]) -> AsyncIterator[Client]:
    """An MCP client connected to `robocog_server` in this process."""
    from mcp import Client

    async with Client(robocog_server, raise_exceptions=True) as client:
        yield client


@pytest.fixture
def robocog_world(robocog_client: Client) -> RobocogWorld:
    """Reset the world, begin tasks and assert their ground truth, through `robocog_client`."""
    return RobocogWorld(robocog_client)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark coroutine tests that use the fixtures `anyio`, unless they are marked for a runner already."""
    for item in items:
        function = getattr(item, "function", None)
        names = set(getattr(item, "fixturenames", ()))
        if function is None or not inspect.iscoroutinefunction(function) or not names & _FIXTURES:
            continue
        if item.get_closest_marker("anyio") is None and item.get_closest_marker("asyncio") is None:
            item.add_marker(pytest.mark.anyio)
