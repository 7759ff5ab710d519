"""The suite's task families, one module each (`put_away`, `swap`, `bring`, `rearrange`, `infeasible`,
`referring`, `memory`, `containers`, `search`; their tasks in `assets/families/ID.yaml`): the draws
the suite generator uses and the prompt readers the scripted planner uses, registered where they are
defined.

How the registry works, and how to add a family, is in `robocog.agent.families.registry`. Importing
this package imports every module in it (sorted by name), so every family is registered before
anything is looked up.
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

from robocog.agent.families.registry import (
    PromptReader,
    RegisteredDraw,
    draw_function,
    draw_specs,
    prompt_readers,
    registered_draws,
)
from robocog.shared.family_files import FAMILIES_DIR, Family
from robocog.shared.family_files import load_families as _load_families
from robocog.shared.family_files import load_family as _load_family

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    importlib.import_module(f"{__name__}.{_module}")


def load_family(path: Path) -> Family:
    """One family file, checked against every registered draw (`robocog.shared.family_files.load_family`)."""
    return _load_family(path, draw_specs())


def load_families(directory: Path = FAMILIES_DIR) -> dict[str, Family]:
    """Every family file of `directory`, by id, checked against every registered draw."""
    return _load_families(directory, draw_specs())


__all__ = [
    "PromptReader",
    "RegisteredDraw",
    "draw_function",
    "draw_specs",
    "load_families",
    "load_family",
    "prompt_readers",
    "registered_draws",
]
