"""The suite's files: a family's YAML and an instance's JSON line are checked, each fault one line
naming its field (and its line), and a prompt writes its lists out."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robocog.agent.families import load_families, load_family
from robocog.shared.errors import ConfigError
from robocog.shared.family_files import render_prompt
from robocog.shared.suite import load_split, load_suite, parse_instances

SUITE = load_suite("robocog-v1")
SPLITS = {split: load_split(SUITE.name, split) for split in SUITE.splits}
INSTANCES = [i for split in SPLITS.values() for i in split]

VALID_FAMILY = """\
id: {id}
title: Bring
description: Bring one item.
variants:
  - id: v
    draw: item_to_location
    prompt: Bring the {{item}} to the {{location}}.
    success:
      - kind: at_location
        objects: ["{{item}}"]
        location: "{{location}}"
"""


def _family_error(tmp_path: Path, text: str, stem: str = "fam") -> str:
    path = tmp_path / f"{stem}.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_family(path)
    return str(err.value)


def test_the_shipped_families_load_and_the_suite_names_only_them() -> None:
    families = load_families()
    v1 = {"put_away", "swap", "bring", "rearrange", "infeasible", "referring", "memory"}
    assert set(SUITE.families) == v1
    assert set(families) == v1 | {"recovery", "containers", "search", "long_horizon"}  # robocog-v2's
    assert families["infeasible"].feasible is False and families["bring"].feasible is True


def test_a_valid_family_loads(tmp_path: Path) -> None:
    path = tmp_path / "fam.yaml"
    path.write_text(VALID_FAMILY.format(id="fam"), encoding="utf-8")
    assert load_family(path).variants[0].draw == "item_to_location"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("{location}.", "{room}."), "prompt: unknown parameter(s) ['room']"),
        (("kind: at_location", "kind: on_shelf"), "does not match any of the expected tags"),
        (("draw: item_to_location", "draw: teleport"), "variants[0].draw: Input should be"),
        (("    success:", "    feasible: false\n    success:"), "an infeasible variant's success is an honest_failure"),
        (("title: Bring\n", ""), "title: Field required"),
        (("    prompt:", "    count: [1, 2]\n    prompt:"), "count: draw 'item_to_location' takes no count"),
        (("    prompt:", "    colour: red\n    prompt:"), "variants[0].colour: Extra inputs are not permitted"),
    ],
)
def test_a_malformed_family_is_one_line_naming_the_field(tmp_path: Path, change: tuple[str, str], message: str) -> None:
    text = VALID_FAMILY.format(id="fam")
    assert change[0] in text
    error = _family_error(tmp_path, text.replace(*change))
    assert message in error and "\n" not in error and "fam.yaml" in error


def test_a_family_s_id_is_its_file_name(tmp_path: Path) -> None:
    assert "must be the file's name" in _family_error(tmp_path, VALID_FAMILY.format(id="other"))


def test_instance_lines_are_validated_with_their_line_numbers() -> None:
    good = INSTANCES[0].model_dump_json()
    assert parse_instances(good + "\n\n", "x.jsonl") == [INSTANCES[0]]
    with pytest.raises(ConfigError, match=r"x.jsonl: line 2: not JSON"):
        parse_instances(good + "\n{oops\n", "x.jsonl")
    with pytest.raises(ConfigError, match=r"line 2: instance id .* is listed twice"):
        parse_instances(good + "\n" + good, "x.jsonl")
    broken = json.loads(good) | {"optimal_steps": -1}
    with pytest.raises(ConfigError, match=r"line 1: optimal_steps: Input should be greater than or equal to 0"):
        parse_instances(json.dumps(broken), "x.jsonl")


def test_prompts_write_lists_out() -> None:
    assert render_prompt("Put {items} on the {f}.", {"items": ["mug"], "f": "Shelf"}) == "Put the mug on the Shelf."
    assert render_prompt("{items}", {"items": ["a", "b", "c"]}) == "the a, the b and the c"
    targets = [["mug", "Shelf", "top"], ["cube", "Door", "floor"]]
    assert render_prompt("{t}.", {"t": targets}) == "the mug on Shelf top, the cube on Door floor."
