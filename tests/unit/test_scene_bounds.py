"""The scene bounds are written once (robocog.shared.scene_bounds) and listed in docs/world.md as they
are; each bound holds at the schema (one value past it is refused, the bound itself is accepted)."""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from robocog.assets import ASSETS_DIR
from robocog.shared import scene_bounds as bounds
from robocog.shared.errors import ConfigError
from robocog.shared.scene_files import load_scene

ROOT = Path(__file__).resolve().parents[2]


def test_the_docs_list_every_bound_as_the_code_has_it() -> None:
    page = (ROOT / "docs" / "world.md").read_text(encoding="utf-8")
    for what, bound in bounds.TABLE:
        assert f"| {what} | {bound} |" in page, (what, bound)


@pytest.fixture(scope="module")
def household() -> dict[str, Any]:
    data: dict[str, Any] = yaml.safe_load((ASSETS_DIR / "scenes" / "household.yaml").read_text(encoding="utf-8"))
    return data


def _load(tmp_path: Path, data: dict[str, Any]) -> None:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    load_scene(path)


CASES: list[tuple[str, Any, Any, str]] = [
    # (where, the bound itself, past it, the field the refusal names)
    ("physics.time_step", bounds.MAX_TIME_STEP_S, bounds.MAX_TIME_STEP_S * 1.01, "physics.time_step"),
    ("physics.time_step", bounds.MIN_TIME_STEP_S, bounds.MIN_TIME_STEP_S * 0.99, "physics.time_step"),
    ("physics.solver_iterations", bounds.SOLVER_ITERATIONS, bounds.SOLVER_ITERATIONS + 1, "physics.solver_iterations"),
    ("objects.0.mass", bounds.MAX_MASS_KG, bounds.MAX_MASS_KG * 1.01, "objects[0].mass"),
    ("objects.0.size", [bounds.OBJECT_M] * 3, [bounds.OBJECT_M * 1.01] * 3, "objects[0].size[0]"),
    ("locations.0.x", bounds.COORD_M, bounds.COORD_M + 0.01, "locations[0].x"),
]


def _set(data: dict[str, Any], where: str, value: Any) -> None:
    *path, last = where.split(".")
    node: Any = data
    for key in path:
        node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
    node[int(last) if last.isdigit() else last] = value


@pytest.mark.parametrize(("where", "ok", "past", "field"), CASES)
def test_a_bound_is_accepted_and_a_value_past_it_refused(
    tmp_path: Path, household: dict[str, Any], where: str, ok: Any, past: Any, field: str
) -> None:
    data = copy.deepcopy(household)
    data["rooms"] = []  # a location moved to the bound lies in no room: the schema alone is checked here
    _set(data, where, ok)
    _load(tmp_path, data)
    _set(data, where, past)
    with pytest.raises(ConfigError, match=f": {re.escape(field)}: "):
        _load(tmp_path, data)
