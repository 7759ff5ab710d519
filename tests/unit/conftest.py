"""Fixtures of the unit tests: one world per test module, reset to the paper's static start before
each test, and a session on it."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from robocog.server.robots.session import RobotSession
from robocog.server.world.world import World
from tests.unit.world_helpers import session_for


@pytest.fixture(scope="module")
def shared_world() -> Iterator[World]:
    """One world for the test module (the `world` fixture resets it)."""
    with World() as w:
        yield w


@pytest.fixture
def world(shared_world: World) -> World:
    """The module's world, reset to the paper's static start."""
    shared_world.reset()
    return shared_world


@pytest.fixture
def robot(world: World) -> RobotSession:
    """A session on the module's world (its memory is never opened)."""
    return session_for(world)
