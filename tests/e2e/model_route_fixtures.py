"""The model-route tests' fixtures: a robot server and a fake model service per test module, and a
clean slate before each test.

The fixtures keep their pytest names (`fake`, `robot`, `fresh`, `anyio_backend`); a test module takes
them with ``from tests.e2e.model_route_fixtures import ...  # noqa: F401``.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator

import pytest

from robocog.agent.client import model as model_service
from robocog.agent.client.connection import Robot, ServerSpec, connect
from tests.e2e.model_routes import HELLO, KEY_VARIABLES, ROUTES
from tests.fake_llm import FakeLLM, Turn


@pytest.fixture(scope="module", name="anyio_backend")
def anyio_backend_fixture() -> str:
    """Module scope, so that one robot server serves every test of a module."""
    return "asyncio"


@pytest.fixture(scope="module", name="fake")
def fake_fixture() -> Iterator[FakeLLM]:
    """The fake model service, started once for the module, each route called once first: the first
    call of a route loads its SDK (seconds), which no test's time budget should pay for."""
    import litellm

    with FakeLLM() as server:
        for model in ROUTES:
            server.reply(Turn(text="ok"))
            litellm.completion(model=model, api_base=server.api_base(model), api_key="sk-warm-up", messages=HELLO)
        server.reset()
        yield server


@pytest.fixture(scope="module", name="robot")
async def robot_fixture(tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[Robot]:
    """The real `robocog-server --profile eval`, spawned over stdio once for the module, and warmed up
    (its world and memory loaded), so that no test's time budget pays for the start."""
    data = tmp_path_factory.mktemp("memory")
    async with connect(ServerSpec(extra_args=["--profile", "eval", "--data-dir", str(data)])) as robot:
        await robot.client.call_tool("clear_memory", {})
        await robot.client.call_tool("reset_world", {})
        yield robot


@pytest.fixture(autouse=True, name="fresh")
def fresh_fixture(fake: FakeLLM, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No key in the environment, no notice said yet, the fake server's record empty."""
    for name in KEY_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(model_service, "_noticed", set())
    fake.reset()
    fake.script = None
    yield
    assert not fake.problems, fake.problems
