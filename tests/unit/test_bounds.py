"""The carrying bound both A* searches share (`robocog.agent.symbolic.bounds`): never more than the
fewest drives a one-handed robot really needs (so the plans stay optimal), and tight on chains."""

from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st

from robocog.agent.symbolic.bounds import carrying_drives

PLACES = "abcd"


def fewest_drives(edges: list[tuple[str, str]], here: str) -> int:
    """The true optimum by brute force: every order of carrying the objects, each carried straight
    from where it lies to its target (a detour never saves a drive), with a drive to each next
    object's location when the robot is not there."""
    moves = [(a, b) for a, b in edges if a != b]
    best = None
    for order in itertools.permutations(moves):
        at, drives = here, 0
        for a, b in order:
            drives += (at != a) + 1
            at = b
        best = drives if best is None else min(best, drives)
    return best or 0


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(st.sampled_from(PLACES), st.sampled_from(PLACES)), max_size=6),
    st.sampled_from(PLACES),
)
def test_the_bound_never_exceeds_the_fewest_drives(edges: list[tuple[str, str]], here: str) -> None:
    assert carrying_drives(edges, here) <= fewest_drives(edges, here)


def test_the_bound_counts_the_drives_between_chains_and_the_first_one() -> None:
    assert carrying_drives([], "a") == 0
    assert carrying_drives([("a", "a")], "a") == 0  # no change of location: no drive
    assert carrying_drives([("a", "b"), ("b", "c")], "a") == 2  # one chain from here
    assert carrying_drives([("a", "b"), ("b", "c")], "c") == 3  # a drive to its start first
    assert carrying_drives([("a", "b"), ("c", "d")], "a") == 3  # two chains: one drive between
    assert carrying_drives([("a", "b"), ("a", "c")], "a") == 3  # both leave a: come back once
    for edges, here in [([("a", "b"), ("c", "d")], "a"), ([("a", "b"), ("a", "c")], "a")]:
        assert carrying_drives(edges, here) == fewest_drives(edges, here)
