"""The generated houses in physics: a sample of the fifty shipped houses (`make bench --only houses` tours
all fifty) built and reset, every object resting on its start position by ground truth, and the oracle
reaching every place position: every container opened, one object carried over every free position with
the world's own actions, resting on each; a drawer's tray is reached from above, over its front."""

from __future__ import annotations

import pytest

from robocog.agent.housegen import house_name
from robocog.server.world.world import World
from tests.house_tour import start_problems, tour

#: The sample: every fifth house (two to five rooms; drawers, cabinets and fridges among them), about 20 s.
SAMPLE = tuple(range(0, 50, 5))


@pytest.mark.parametrize("seed", SAMPLE)
def test_the_oracle_reaches_every_position_of_a_generated_house(seed: int) -> None:
    with World(house_name(seed)) as world:
        world.reset()
        assert start_problems(world) == []
        reached, tried, problems = tour(world)
        assert problems == [] and reached == tried >= 5


def test_a_generated_house_resets_to_the_same_state() -> None:
    with World(house_name(0)) as world:
        first = world.reset()
        assert first == world.reset()
