"""The one name normaliser (`robocog.shared.names.name_key`) gives every caller what its own
normaliser gave before, on the inputs each sees: the scenes' names and descriptions and the texts
the suite generator looks up (shared/scene.py's `referring_key`), the prompts of both shipped splits
and every phrase the planner cuts from them (the planner's reader), and the names the world tools'
tests give them (server/world/navigation.py's `normalise` and `strip_articles`)."""

from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Any

import pytest

import robocog.agent.families.reading as reading
import robocog.server.world.navigation as navigation
import robocog.shared.scene as scene_module
from robocog.agent.policies.belief import Belief
from robocog.agent.policies.history import understand
from robocog.agent.suitegen.generator import generate
from robocog.shared.names import name_key
from robocog.shared.scene import Scene
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import Instance, load_split, load_suite

UNIT_TESTS = Path(__file__).parent
SCENES = ("household", "suite_house", "flat")

# --- yesterday's three normalisers, verbatim: the behaviour to keep --------------------------------


def old_referring_key(text: str) -> str:
    """shared/scene.py's `referring_key`."""
    return re.compile(r"^(?:the|an?)(?:\s+|$)", re.IGNORECASE).sub("", " ".join(text.split()).lower())


def old_clean(text: str) -> str:
    """The planner's `_clean` (agent/policies/belief.py, then agent/families/reading.py's `clean`)."""
    text = re.sub(r"\s+", " ", text.lower()).strip(" .!?;:,")
    return re.sub(r"^(?:the|a|an) ", "", text)


def old_normalise(name: str) -> str:
    """server/world/navigation.py's `normalise`."""
    return re.sub(r"[\s_\-]+", " ", name).strip().casefold()


def old_strip_articles(name: str) -> str:
    """server/world/navigation.py's `strip_articles`."""
    return " ".join(w for w in old_normalise(name).split() if w not in {"the", "a", "an"})


# --- the inputs ------------------------------------------------------------------------------------


def scene_names(scene: Scene) -> list[str]:
    """Every name and description a scene has."""
    return [
        *(o.name for o in scene.objects),
        *(d for o in scene.objects for d in o.descriptions),
        *(loc.name for loc in scene.locations),
        *(p.name for p in scene.place_positions),
        *(f.name for f in scene.furniture),
        *(f.name.replace("_", " ") for f in scene.furniture),
    ]


def first_look(scene: Scene, instance: Instance) -> Belief:
    """What the planner's first look around shows at an instance's start."""
    where = {o: (s.location, s.position) for o, s in instance.start.items()}
    neighbours: dict[str, list[str]] = {loc.name: [] for loc in scene.locations}
    for a, b in scene.edges:
        neighbours[a].append(b)
        neighbours[b].append(a)
    look: dict[str, Any] = {
        "location": scene.robot_start,
        "locations": [
            {
                "name": loc,
                "neighbours": near,
                "objects": [o for o, w in where.items() if w[0] == loc],
                "place_positions": [
                    {"name": p.name, "occupied_by": next((o for o, w in where.items() if w == (loc, p.name)), None)}
                    for p in scene.place_positions
                    if p.location == loc
                ],
            }
            for loc, near in neighbours.items()
        ],
    }
    return Belief.from_look(look)


def tool_names() -> list[str]:
    """The names the world tools' tests give the tools and `closest`/`strip_articles`: keyword
    arguments object/location/position/direction and the first string of each parametrized case."""
    found: list[str] = []
    for path in sorted(UNIT_TESTS.glob("test_world*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.keyword) and node.arg in ("object", "location", "position", "direction"):
                found += _text(node.value)
            elif isinstance(node, ast.Tuple) and len(node.elts) == 3:  # (name, known, expected)
                found += _text(node.elts[0])
            elif isinstance(node, ast.Call) and getattr(node.func, "id", "") in ("closest", "strip_articles"):
                found += _text(node.args[0]) if node.args else []
    return found


def _text(node: ast.expr) -> list[str]:
    return [node.value] if isinstance(node, ast.Constant) and isinstance(node.value, str) else []


@pytest.fixture(scope="module")
def scenes() -> dict[str, Scene]:
    return {name: load_scene(scene_path(name)) for name in SCENES}


def spying(monkeypatch: pytest.MonkeyPatch, module: Any) -> list[str]:
    """Record every text `module` hands the normaliser."""
    seen: list[str] = []

    def spy(text: str, **options: Any) -> str:
        seen.append(text)
        return name_key(text, **options)

    monkeypatch.setattr(module, "name_key", spy)
    return seen


# --- each caller, unchanged -------------------------------------------------------------------------


def test_referring_keys_are_unchanged_on_the_scenes_and_the_generator_s_lookups(
    monkeypatch: pytest.MonkeyPatch, scenes: dict[str, Scene]
) -> None:
    seen = spying(monkeypatch, scene_module)
    for name in SCENES:
        load_scene(scene_path(name))  # validation compares names and descriptions
    suite = load_suite("robocog-v1")  # the hand-made scenes' names
    for split in suite.splits:
        generate(suite, split)  # the referring and infeasible families look texts up
    described = [t for s in scenes.values() for o in s.objects for t in (o.name, *o.descriptions)]
    inputs = {*seen, *described}
    assert len(inputs) > 30 and set(described) <= set(seen)
    for text in sorted(inputs):
        assert name_key(text) == old_referring_key(text), text


def test_the_planner_reads_every_prompt_of_both_splits_as_before(
    monkeypatch: pytest.MonkeyPatch, scenes: dict[str, Scene]
) -> None:
    seen = spying(monkeypatch, reading)
    for split in ("dev", "test"):
        for instance in load_split("robocog-v1", split):
            first = first_look(scenes[instance.scene], instance)
            for prompt in [*(s.prompt for s in instance.prelude), instance.prompt]:
                understand(prompt, first, set())
    assert len(set(seen)) > 200
    for text in sorted(set(seen)):
        assert name_key(text) == old_clean(text), text


def test_the_tools_name_matching_is_unchanged_on_the_names_they_are_given(scenes: dict[str, Scene]) -> None:
    given = tool_names()
    assert {"the shelf", "Kitchen Shelve", "cub", "the", "FLOOR", "the Kitchen Shelf"} <= set(given)
    inputs = {*given, *(t for s in scenes.values() for t in scene_names(s)), "  The Kitchen_Shelf ", "an"}
    for text in sorted(inputs):
        assert navigation.normalise(text) == old_normalise(text), text
        assert navigation.strip_articles(text) == old_strip_articles(text), text


# --- the rule itself --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "leading", "every", "kept"),
    [
        ("The  Drinking vessel.", "drinking vessel", "drinking vessel", "the drinking vessel"),
        ("  the Kitchen_Shelf ", "kitchen shelf", "kitchen shelf", "the kitchen shelf"),
        ("put it on the top-shelf!", "put it on the top shelf", "put it on top shelf", "put it on the top shelf"),
        ("an", "", "", "an"),
        ("A cup, please?", "cup, please", "cup, please", "a cup, please"),
        ("", "", "", ""),
    ],
)
def test_one_rule_with_a_choice_of_articles(text: str, leading: str, every: str, kept: str) -> None:
    assert name_key(text) == name_key(text, articles="leading") == leading
    assert name_key(text, articles="all") == every
    assert name_key(text, articles="keep") == kept
