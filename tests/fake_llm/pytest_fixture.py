"""The ``fake_llm`` pytest fixture: a started server with no script yet."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.fake_llm.server import FakeLLM


@pytest.fixture(name="fake_llm")
def fake_llm_fixture() -> Iterator[FakeLLM]:
    """The ``fake_llm`` fixture: a started `FakeLLM` with no script (set ``.script`` or call ``.reply(...)``).

    Use it with ``from tests.fake_llm.pytest_fixture import fake_llm_fixture  # noqa: F401`` in a test module.
    """
    with FakeLLM() as server:
        yield server
    assert not server.problems, server.problems
