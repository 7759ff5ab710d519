"""Task families as data (`assets/families/*.yaml`): a family's variants, their prompt and success
templates, how templates are rendered, and the capability tags instances carry.

A family is a kind of task (put away, swap, bring, ...) in one or more *variants*. A variant names
how its parameters are drawn from a scene and a start state (`draw`), and holds the prompt and the
success conditions as templates over those parameters: in a prompt `{items}` is written out ("the
mug, the box and the bottle"); in a success condition a field that is exactly `"{items}"` takes the
parameter's value (a list stays a list).

The draws are implemented, and declared (`DrawSpec`: the parameters each gives, the variant fields it
takes), where they are defined: in the family modules of `robocog.agent.families`, which this package
cannot import. So a family file's draw names and templates are checked against the declarations the
caller passes in (`load_family(path, draws)`; `robocog.agent.families.load_family` passes them all);
without them only what needs no draw is checked (the server and a study's config need only the ids).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, ValidationInfo, model_validator

from robocog.assets import ASSETS_DIR
from robocog.shared.config_files import load_yaml_model, validation_problems
from robocog.shared.errors import ConfigError
from robocog.shared.results import Observe
from robocog.shared.tasks import Condition

FAMILIES_DIR = ASSETS_DIR / "families"

Id = Annotated[str, Field(pattern=r"^[A-Za-z0-9_\-]+$", min_length=1, max_length=120)]

#: A variant field that only some draws take (and those draws need).
Takes = Literal["count", "choices", "prelude"]

#: What an instance measures, as EmbodiedBench reports subsets: every instance of a tagged suite
#: (robocog-v2) carries one or more of these, from its family and variant and from what it is (an
#: infeasible one measures honesty, one with perturbations recovery, ...: `derived_capabilities`).
Capability = Literal[
    "planning", "recovery", "memory", "honesty", "referring", "long_horizon", "partial_observation", "containers"
]
CAPABILITIES: tuple[Capability, ...] = (
    "planning",
    "recovery",
    "memory",
    "honesty",
    "referring",
    "long_horizon",
    "partial_observation",
    "containers",
)
#: An optimal plan of at least this many robot actions makes an instance long-horizon.
LONG_HORIZON_STEPS = 30


@dataclass(frozen=True)
class DrawSpec:
    """How a variant's parameters are drawn, as its templates see it: the draw's name, the parameters it
    gives (each with an example value of its shape, to check the templates when a family is loaded)
    and the variant fields it takes (it needs them, and no other draw takes them)."""

    name: str
    gives: Mapping[str, Any]
    takes: frozenset[Takes] = field(default_factory=frozenset)


_CONDITIONS: TypeAdapter[list[Condition]] = TypeAdapter(list[Condition])
_PLACEHOLDER = re.compile(r"\{([A-Za-z_]\w*)\}")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --- rendering templates ---------------------------------------------------------------------------


def phrase(value: Any) -> str:
    """A parameter as the prompt writes it: a list of names "the a, the b and the c", a list of
    (object, location, position) "the a on L P, the b on L P", anything else as it is."""
    if isinstance(value, list | tuple) and value and all(isinstance(v, list | tuple) for v in value):
        parts = [f"the {o} on {loc} {pos}" for o, loc, pos in value]
        return ", ".join(parts)
    if isinstance(value, list | tuple):
        names = [f"the {v}" for v in value]
        return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return str(value)


def render_prompt(template: str, parameters: dict[str, Any]) -> str:
    """The prompt `template` with each `{name}` written out (`phrase`)."""
    return _PLACEHOLDER.sub(lambda m: phrase(parameters[m.group(1)]), template)


def _fill(node: Any, parameters: dict[str, Any]) -> Any:
    if isinstance(node, str):
        whole = _PLACEHOLDER.fullmatch(node)
        if whole:
            return parameters[whole.group(1)]
        return _PLACEHOLDER.sub(lambda m: str(parameters[m.group(1)]), node)
    if isinstance(node, list):
        return [_fill(v, parameters) for v in node]
    if isinstance(node, dict):
        return {k: _fill(v, parameters) for k, v in node.items()}
    return node


def render_success(template: list[dict[str, Any]], parameters: dict[str, Any]) -> list[Condition]:
    """The success conditions of `template` with the parameters filled in, validated."""
    return _CONDITIONS.validate_python(_fill(template, parameters))


def _placeholders(node: Any) -> set[str]:
    if isinstance(node, str):
        return set(_PLACEHOLDER.findall(node))
    if isinstance(node, list):
        return set().union(*(_placeholders(v) for v in node)) if node else set()
    if isinstance(node, dict):
        return set().union(*(_placeholders(v) for v in node.values())) if node else set()
    return set()


# --- families --------------------------------------------------------------------------------------


class StepTemplate(_Strict):
    """An earlier task of a variant, run in the same world (memory kept) before the task itself."""

    prompt: str = Field(min_length=1)
    success: list[dict[str, Any]] = Field(min_length=1)


class Variant(_Strict):
    """One way a family's task is posed: how its parameters are drawn, its prompt and success."""

    id: Id
    draw: Id = Field(description="how the parameters are drawn: a draw of a family module (robocog.agent.families)")
    prompt: str = Field(min_length=1, description="the instruction, with {parameter} placeholders")
    success: list[dict[str, Any]] = Field(min_length=1, description="success conditions, with placeholders")
    feasible: bool = True
    count: tuple[int, int] | None = Field(default=None, description="fewest and most items (for a draw that takes it)")
    choices: list[str] = Field(default=[], description="names to draw from (for a draw that takes them)")
    prelude: list[StepTemplate] = Field(
        default=[], description="earlier tasks in the same world (for a draw that takes them)"
    )
    example: str = Field(default="", description="an instance's prompt, for the README and `robocog suite list`")
    capabilities: list[Capability] = Field(default=[], description="capability tags of this variant's instances")
    min_optimal_steps: int | None = Field(
        default=None, ge=1, description="the generator rejects an instance whose optimal plan is shorter"
    )
    observe: Observe | None = Field(
        default=None, description="what look_around reveals in this variant's instances (default: the study's)"
    )
    weight: int = Field(
        default=1, ge=1, le=100, description="how often the generator tries this variant against the others"
    )

    @model_validator(mode="after")
    def _templates(self, info: ValidationInfo) -> Variant:
        """Checks the templates against the draw's declaration when the loader passes the draws in
        (validation context `draws`: name -> `DrawSpec`), and what needs no draw always."""
        draws: Mapping[str, DrawSpec] | None = (info.context or {}).get("draws")
        spec = self._check_draw(draws) if draws is not None else None
        honest = any(c.get("kind") == "honest_failure" for c in self.success)
        if honest == self.feasible:
            raise ValueError(
                "success: an infeasible variant's success is an honest_failure, and only an infeasible one's"
            )
        if spec is not None and ("count" in spec.takes) != (self.count is not None):
            raise ValueError(f"count: draw {self.draw!r} " + ("needs" if self.count is None else "takes no") + " count")
        if self.count is not None and not 1 <= self.count[0] <= self.count[1]:
            raise ValueError(f"count: wants [fewest, most] with 1 <= fewest <= most, not {list(self.count)}")
        if spec is not None and ("choices" in spec.takes) != bool(self.choices):
            raise ValueError(
                f"choices: draw {self.draw!r} " + ("needs" if not self.choices else "takes no") + " choices"
            )
        if spec is not None and ("prelude" in spec.takes) != bool(self.prelude):
            raise ValueError(
                f"prelude: draw {self.draw!r} " + ("needs a" if not self.prelude else "takes no") + " prelude"
            )
        return self

    def _check_draw(self, draws: Mapping[str, DrawSpec]) -> DrawSpec:
        """The declaration of this variant's draw, which must be one of `draws`; the templates must
        use only the parameters it gives, and render to valid conditions with its example values."""
        if self.draw not in draws:
            names = [repr(n) for n in sorted(draws)] or ["a registered draw (there is none)"]
            expected = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " or " + names[-1]
            raise ValueError(f"draw: Input should be {expected}")
        spec = draws[self.draw]
        known = set(spec.gives)
        parts: list[tuple[str, Any]] = [("prompt", self.prompt), ("success", self.success)]
        for i, step in enumerate(self.prelude):
            parts += [(f"prelude[{i}].prompt", step.prompt), (f"prelude[{i}].success", step.success)]
        for where, node in parts:
            unknown = sorted(_placeholders(node) - known)
            if unknown:
                raise ValueError(f"{where}: unknown parameter(s) {unknown}; draw {self.draw!r} gives {sorted(known)}")
        for where, template in [("success", self.success)] + [
            (f"prelude[{i}].success", s.success) for i, s in enumerate(self.prelude)
        ]:
            try:
                render_success(template, dict(spec.gives))
            except ValidationError as exc:
                raise ValueError(f"{where}: {validation_problems(exc)}") from None
        return spec


class Family(_Strict):
    """A kind of task, in one or more variants (`assets/families/ID.yaml`)."""

    id: Id
    title: str = Field(min_length=1)
    description: str = Field(min_length=1, description="what the family measures")
    capabilities: list[Capability] = Field(default=[], description="capability tags of every instance of the family")
    variants: list[Variant] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique(self) -> Family:
        ids = [v.id for v in self.variants]
        if len(set(ids)) != len(ids):
            raise ValueError(f"variants: two variants share an id ({ids})")
        return self

    @property
    def feasible(self) -> bool | None:
        """True or False when every variant is, None when they differ."""
        kinds = {v.feasible for v in self.variants}
        return kinds.pop() if len(kinds) == 1 else None


class _Document(BaseModel):
    """A YAML file's mapping as it is, read and checked as every config file is (then validated)."""

    model_config = ConfigDict(extra="allow")


def load_family(path: Path, draws: Mapping[str, DrawSpec] | None = None) -> Family:
    """One family file; its id must be its file's stem. With `draws` (name -> declaration), each
    variant's draw must be one of them and its templates must fit the draw's declaration."""
    data = load_yaml_model(path, _Document).model_extra
    try:
        family = Family.model_validate(data, context={"draws": draws})
    except ValidationError as exc:
        raise ConfigError(f"{path}: {validation_problems(exc)}") from exc
    if family.id != path.stem:
        raise ConfigError(f"{path}: id: {family.id!r} must be the file's name ({path.stem!r})")
    return family


def load_families(directory: Path = FAMILIES_DIR, draws: Mapping[str, DrawSpec] | None = None) -> dict[str, Family]:
    """Every family of `directory` (`*.yaml`), by id, in file-name order (checked against `draws` when given)."""
    return {f.id: f for f in (load_family(p, draws) for p in sorted(directory.glob("*.yaml")))}
