"""`robocog run --observe` (issue 42): what look_around shows, passed to the server the run spawns."""

from __future__ import annotations

import pytest

from robocog.agent.cli.main import build_parser
from robocog.agent.cli.options import server_spec


@pytest.mark.parametrize("observe", ["location", "room", "house"])
def test_run_passes_observe_to_the_server_it_spawns(observe: str) -> None:
    args = build_parser().parse_args(["run", "T1", "--model", "scripted/planner", "--observe", observe])
    extra = server_spec(args).extra_args
    assert extra[extra.index("--observe") + 1] == observe


def test_without_observe_the_server_shows_what_it_shows_by_default() -> None:
    args = build_parser().parse_args(["run", "T1", "--model", "scripted/planner"])
    assert "--observe" not in server_spec(args).extra_args
    with pytest.raises(SystemExit):
        build_parser().parse_args(["run", "T1", "--observe", "garden"])
