"""The task families' registry (`robocog.agent.families`): every draw a family file names is
registered by its family's module, every registered draw is used, a family module registers its
draw and its prompt reader when it is imported, and the planner reads every variant's example
prompt into goals (or, for an infeasible one, into the reason it cannot be done)."""

from __future__ import annotations

import importlib.util
import random
import re
from pathlib import Path
from typing import Any

import pytest

from robocog.agent.families import (
    draw_specs,
    load_families,
    load_family,
    prompt_readers,
    registered_draws,
    registry,
)
from robocog.agent.families.reading import Request
from robocog.agent.policies.belief import Belief, Goal
from robocog.agent.policies.history import understand
from robocog.agent.symbolic.world import SceneNames
from robocog.shared.errors import ConfigError
from robocog.shared.family_files import FAMILIES_DIR
from robocog.shared.family_files import load_family as load_family_unchecked
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import families_dir, load_suite

FAMILIES = load_families()
#: robocog-v2.1's own copies of the family files (assets/suites/robocog-v2.1/families).
V21_FAMILIES = load_families(families_dir("robocog-v2.1", load_suite("robocog-v2.1")))
VARIANTS = [(f.id, v) for f in FAMILIES.values() for v in f.variants]
EVERY_VARIANT = [*VARIANTS, *((f"v2.1-{f.id}", v) for f in V21_FAMILIES.values() for v in f.variants)]


def _look(where: dict[str, tuple[str, str | None]]) -> dict[str, Any]:
    """A look around at the Front Door of the paper's house, with the objects `where`."""
    layout = {
        "Front Door": (["Hallway Area Door"], ["floor"]),
        "Hallway Area Door": (["Front Door", "Kitchen Door", "Living Room Door"], ["floor"]),
        "Kitchen Door": (["Hallway Area Door", "Kitchen Area Left"], []),
        "Living Room Door": (["Hallway Area Door", "Living Room"], []),
        "Kitchen Area Left": (["Kitchen Door", "Kitchen Shelf", "Kitchen Table"], ["floor"]),
        "Kitchen Shelf": (["Kitchen Area Left"], ["top", "middle", "bottom"]),
        "Kitchen Table": (["Kitchen Area Left"], ["middle"]),
        "Living Room": (["Living Room Door", "Living Room TV"], ["floor"]),
        "Living Room TV": (["Living Room"], []),
    }
    return {
        "location": "Front Door",
        "holding": None,
        "message": "The robot is at Front Door, holding nothing. Here: no objects. Seen: mug (white, medium), "
        "cube (red, small), box (brown, medium), tv (black, large).",
        "locations": [
            {
                "name": name,
                "neighbours": near,
                "objects": [o for o, (loc, _) in where.items() if loc == name],
                "place_positions": [
                    {"name": p, "occupied_by": next((o for o, w in where.items() if w == (name, p)), None)}
                    for p in positions
                ],
            }
            for name, (near, positions) in layout.items()
        ],
    }


HOUSE = Belief.from_look(
    _look(
        {
            "mug": ("Kitchen Shelf", "top"),
            "cube": ("Kitchen Table", "middle"),
            "box": ("Living Room", "floor"),
            "tv": ("Living Room TV", None),
        }
    )
)
#: The house with a fridge, a drawer and a cabinet off the kitchen, all closed (nothing inside shows).
KITCHEN = HOUSE.copy()
KITCHEN.containers = {
    "kitchen_fridge": "Kitchen Fridge",
    "kitchen_drawer": "Kitchen Drawer",
    "kitchen_cabinet": "Cabinet",
}
KITCHEN.closed = set(KITCHEN.containers)
KITCHEN.neighbours = {**HOUSE.neighbours, **{loc: ["Kitchen Area Left"] for loc in KITCHEN.containers.values()}}
#: What search_memory would find after a task that brought every item to the Front Door.
MEMORIES = [
    {
        "when": "2026-01-01T00:00:00",
        "summary": "Result: "
        + "; ".join(
            f"the {o} is on Front Door / floor (it was on {loc} / {pos})"
            for o, (loc, pos) in HOUSE.where.items()
            if pos is not None
        )
        + ".",
    }
]


# --- the registry against the family files ---------------------------------------------------------


def test_every_draw_a_family_file_names_is_registered_by_that_family_s_module() -> None:
    draws = registered_draws()
    for family, variant in VARIANTS:
        assert variant.draw in draws, (family, variant.id)
        assert draws[variant.draw].family == family, (family, variant.id)
        assert draws[variant.draw].make.__module__ == f"robocog.agent.families.{family}"


def test_every_registered_draw_is_used_by_a_family_file() -> None:
    used = {v.draw for _, v in EVERY_VARIANT}
    assert set(registered_draws()) == used


def test_every_family_file_has_its_module() -> None:
    for family in FAMILIES:
        assert importlib.util.find_spec(f"robocog.agent.families.{family}") is not None, family


def test_the_planner_asks_the_readers_in_the_documented_order() -> None:
    order = [(r.order, r.family) for r in prompt_readers()]
    assert order == [
        (10, "memory"),
        (20, "swap"),
        (25, "long_horizon"),
        (30, "rearrange"),
        (35, "containers"),
        (40, "bring"),
        (50, "search"),
    ]
    # "put the mug back" is a transport prompt too: the memory family's reader is asked first.
    assert [r.family for r in prompt_readers() if r.pattern.match("put the mug back where it was")] == [
        "memory",
        "bring",
    ]


def test_the_shared_loader_checks_draws_only_against_the_declarations_it_is_given(tmp_path: Path) -> None:
    text = (FAMILIES_DIR / "bring.yaml").read_text(encoding="utf-8").replace("{location}.", "{room}.")
    path = tmp_path / "bring.yaml"
    path.write_text(text, encoding="utf-8")
    assert load_family_unchecked(path).variants[0].draw == "item_to_location"  # no draws: not checked
    with pytest.raises(ConfigError, match=r"prompt: unknown parameter\(s\) \['room'\]"):
        load_family_unchecked(path, draw_specs())
    with pytest.raises(ConfigError, match=r"variants\[0\].draw: Input should be 'absent_to_location'$"):
        load_family_unchecked(path, {"absent_to_location": draw_specs()["absent_to_location"]})


def test_a_draw_or_a_reader_order_cannot_be_registered_twice() -> None:
    with pytest.raises(ValueError, match="draw 'pair' is registered twice"):
        registry.draw("pair", gives={"a": "mug", "b": "cube"})(registered_draws()["pair"].make)
    with pytest.raises(ValueError, match="reader order 20 is taken"):
        registry.reader(r"^exchange (.+)$", order=20)(prompt_readers()[1].read)


# --- adding a family: a YAML and a module ---------------------------------------------------------

NEW_MODULE = """
import random
import re
from typing import Any

from robocog.agent.families.reading import FirstLook, Goal, Request, resolve_object
from robocog.agent.families.registry import draw, reader
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import Variant


@draw("one_item", gives={"item": "mug"})
def one_item(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    return {"item": rng.choice(world.graspable)}


@reader(r"^tidy up (.+)$", order=5)
def read_tidy(match: re.Match[str], first: FirstLook, memories: list[dict[str, Any]]) -> Request | None:
    found, problem = resolve_object(match.group(1), first)
    return Request("tidy", {found: Goal("Kitchen Shelf")} if found else {}, problem=problem)
"""

NEW_FAMILY = """\
id: tidy
title: Tidy up
description: One item onto the shelf.
variants:
  - id: shelf
    draw: one_item
    prompt: Tidy up the {item}.
    example: Tidy up the mug.
    success:
      - kind: at_location
        objects: ["{item}"]
        location: Kitchen Shelf
"""


def test_a_family_module_registers_its_draw_and_reader_when_it_is_imported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(registry, "_DRAWS", dict(registry._DRAWS))
    monkeypatch.setattr(registry, "_READERS", list(registry._READERS))
    (tmp_path / "tidy.py").write_text(NEW_MODULE, encoding="utf-8")
    (tmp_path / "tidy.yaml").write_text(NEW_FAMILY, encoding="utf-8")
    with pytest.raises(ConfigError, match="draw: Input should be"):
        load_family(tmp_path / "tidy.yaml")

    spec = importlib.util.spec_from_file_location("robocog.agent.families.tidy", tmp_path / "tidy.py")
    assert spec is not None and spec.loader is not None
    spec.loader.exec_module(importlib.util.module_from_spec(spec))

    assert registered_draws()["one_item"].family == "tidy"
    assert [r.family for r in prompt_readers()][:2] == ["tidy", "memory"]
    family = load_family(tmp_path / "tidy.yaml")
    house = SceneNames(load_scene(scene_path("household")))
    params = registered_draws()["one_item"].make(random.Random(1), house, {}, family.variants[0])
    assert params is not None and params["item"] in house.graspable
    request = understand(family.variants[0].example, HOUSE, set())
    assert request == Request("tidy", {"mug": Goal("Kitchen Shelf")})


# --- the planner reads every variant's example -----------------------------------------------------


@pytest.mark.parametrize(("family", "variant"), EVERY_VARIANT, ids=[f"{f}-{v.id}" for f, v in EVERY_VARIANT])
def test_the_planner_reads_every_variant_s_example_prompt(family: str, variant: Any) -> None:
    """A feasible example into goals it can meet; an infeasible one into why not (memory knows the TV
    cannot be grasped, as it would after a first try), unless what makes it infeasible is what goes
    wrong during it (its draw gives perturbations: a corridor blocked for good): that it finds out
    by acting. A description only a house's file gives ("the drinking vessel", robocog-v1's and v2's)
    is no longer the planner's to resolve: it says it cannot find it."""
    assert variant.example, f"{family}/{variant.id} has no example prompt"
    family = family.removeprefix("v2.1-")
    if variant.draw == "description_to_location":
        request = understand(variant.example, HOUSE, set(), MEMORIES)
        assert request is not None and request.problem == "there is no drinking vessel here", request
        return
    first = KITCHEN if family == "containers" or variant.id == "closed" else HOUSE
    request = understand(variant.example, first, {"tv"}, MEMORIES)
    assert isinstance(request, Request), variant.example
    if variant.feasible:
        assert request.goals and request.problem is None, (variant.example, request)
        assert set(request.goals) <= set(first.where) or request.look_in, request  # or shut in a container
        assert all(re.fullmatch(r"[A-Z][\w ]+", g.location) for g in request.goals.values())
    elif "perturbations" in draw_specs()[variant.draw].gives:
        assert request.goals and request.problem is None, (variant.example, request)
    else:
        assert request.problem, (variant.example, request)


def test_a_memory_example_reads_where_the_item_was() -> None:
    example = FAMILIES["memory"].variants[0].example
    request = understand(example, HOUSE, set(), MEMORIES)
    assert request is not None and request.goals == {"mug": Goal("Kitchen Shelf", "top")}
    assert request.recall == "mug"
