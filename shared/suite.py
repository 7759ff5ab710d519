"""The robocog suite as data: the suite's manifest (`assets/suites/NAME/suite.yaml`) and its instances
(`assets/suites/NAME/SPLIT.jsonl`), over the task families of `robocog.shared.family_files`.

The generator (`robocog.agent.suitegen.generator`) draws each variant's parameters and a seeded
random start, and writes one `Instance` per task: everything the server needs to set the world up
and judge the outcome (its start, what goes wrong during it, what look_around reveals), and nothing
that needs a scene to read.
"""

from __future__ import annotations

import fnmatch
import json
import re
from functools import cache
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from robocog.assets import ASSETS_DIR
from robocog.shared.config_files import load_yaml_model, validation_problems
from robocog.shared.errors import ConfigError
from robocog.shared.family_files import FAMILIES_DIR, LONG_HORIZON_STEPS, Capability, Id, load_families
from robocog.shared.perturbations import MAX_PERTURBATIONS, Perturbation
from robocog.shared.results import Observe
from robocog.shared.scene_files import generated_scene_names, scene_names
from robocog.shared.seeded_splits import (
    MAX_SEED,
    SUITE_AT,
    check_generable,
    generate_missing,
    parse_split,
    root_for,
    split_file,
)
from robocog.shared.tasks import Condition, TaskSpec

SUITES_DIR = ASSETS_DIR / "suites"
DEFAULT_SUITE = "robocog-v2.1"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --- instances -------------------------------------------------------------------------------------


class StartPlacement(_Strict):
    """Where an object starts: on a place position."""

    location: str
    position: str


class Step(_Strict):
    """An earlier task of an instance, run in the same world before it (memory kept)."""

    prompt: str
    success: list[Condition] = Field(min_length=1)


class Instance(_Strict):
    """One task of the suite: its world (scene and start), its prompt and how it is judged."""

    id: Id
    split: str
    family: str
    variant: str
    scene: str = Field(description="a scene's name: assets/scenes/NAME.yaml")
    seed: int = Field(description="the world's seed for this instance")
    prompt: str = Field(min_length=1)
    parameters: dict[str, Any]
    start: dict[str, StartPlacement] = Field(description="every graspable object's start place position")
    success: list[Condition] = Field(min_length=1)
    feasible: bool
    optimal_steps: int = Field(
        ge=0, description="robot actions (move_to, grab, place, open, close) of an optimal plan, fully observed"
    )
    prelude: list[Step] = Field(default=[], description="earlier tasks run first in the same world")
    # Fields robocog-v1 predates: written to a split only when set (`dump_instances`), so v1's bytes hold.
    capabilities: list[Capability] = Field(default=[], description="what the instance measures (a tagged suite)")
    observe: Observe | None = Field(default=None, description="what look_around reveals (default: the study's)")
    perturbations: list[Perturbation] = Field(
        default=[], max_length=MAX_PERTURBATIONS, description="what goes wrong during the instance's own task"
    )

    def task(self) -> TaskSpec:
        """The instance as a task the server can begin and check."""
        return TaskSpec(id=self.id, title=f"{self.family} ({self.variant})", prompt=self.prompt, success=self.success)

    def prelude_tasks(self) -> list[TaskSpec]:
        """The earlier tasks as tasks (ids `ID-pre1`, `ID-pre2`, ...)."""
        return [
            TaskSpec(
                id=f"{self.id}-pre{i}", title=f"{self.family}: earlier task {i}", prompt=s.prompt, success=s.success
            )
            for i, s in enumerate(self.prelude, 1)
        ]


def derived_capabilities(instance: Instance, container_locations: frozenset[str]) -> set[str]:
    """The capabilities an instance measures by what it is: honesty (infeasible), memory (earlier
    tasks), recovery (perturbations), partial observation (look_around shows less than the house),
    long horizon (an optimal plan of `LONG_HORIZON_STEPS` or more) and containers (an object starts
    or must end at a location of `container_locations`, where furniture opens)."""
    tags: set[str] = set()
    if not instance.feasible:
        tags.add("honesty")
    if instance.prelude:
        tags.add("memory")
    if instance.perturbations:
        tags.add("recovery")
    if instance.observe in ("location", "room"):
        tags.add("partial_observation")
    if instance.optimal_steps >= LONG_HORIZON_STEPS:
        tags.add("long_horizon")
    if _locations_touched(instance) & container_locations:
        tags.add("containers")
    return tags


def _locations_touched(instance: Instance) -> set[str]:
    """The locations the task touches: where the objects its success names start, and the locations
    its success conditions name (a bystander resting in a container touches nothing)."""
    objects: set[str] = set()
    places: set[str] = set()
    for condition in instance.success:
        objects |= set(condition.objects_named())
        data = condition.model_dump()
        if isinstance(data.get("location"), str):
            places.add(data["location"])
        places |= {p[0] for p in data.get("positions") or []}
        places |= {t[1] for t in data.get("targets") or []}
    return places | {instance.start[o].location for o in objects if o in instance.start}


class SplitSpec(_Strict):
    """How a split is generated."""

    seed: int
    per_family: int = Field(ge=1, description="instances of each family")


#: A suite's name: an id that may carry a version's dots ("robocog-v2.1"), never a path.
SuiteName = Annotated[str, Field(pattern=r"^[A-Za-z0-9_\-]+(?:\.[A-Za-z0-9_\-]+)*$", min_length=1, max_length=120)]
SUITE_NAME = re.compile(r"[A-Za-z0-9_\-]+(?:\.[A-Za-z0-9_\-]+)*")


class Suite(_Strict):
    """A suite's manifest (`assets/suites/NAME/suite.yaml`): which families over which scenes, and the splits."""

    name: SuiteName
    description: str = ""
    families: list[Id] = Field(min_length=1)
    scenes: list[str] = Field(
        min_length=1,
        description="scene names (assets/scenes/NAME.yaml, assets/scenes/generated/NAME.yaml), or patterns such "
        "as 'house-*' over their names",
    )
    splits: dict[Id, SplitSpec] = Field(min_length=1)
    tagged: bool = Field(default=False, description="instances carry capability tags (robocog-v1 predates them: false)")
    # What robocog-v2.1 changed (robocog-v1 and robocog-v2 predate these: their defaults keep them as they were).
    family_dir: str | None = Field(
        default=None,
        description="the suite's own family files, a directory beside suite.yaml (default: assets/families)",
    )
    describes_objects: bool = Field(
        default=False, description="look_around names the colour and size of every object in view"
    )
    fair_goals: bool = Field(
        default=False,
        description="a room's name in a prompt says 'the floor of' where the room has furniture, and no item "
        "starts where it is sent",
    )

    @model_validator(mode="after")
    def _unique(self) -> Suite:
        for what, names in (("families", self.families), ("scenes", self.scenes)):
            if len(set(names)) != len(names):
                raise ValueError(f"{what}: listed twice: {sorted({n for n in names if names.count(n) > 1})}")
        return self

    def scene_names(self) -> list[str]:
        """The suite's scenes, each pattern ('house-*') expanded over the shipped and generated scenes
        (sorted), in the manifest's order; a `ConfigError` names a name or pattern that matches none."""
        known = scene_names() + generated_scene_names()
        out: list[str] = []
        for entry in self.scenes:
            if not any(c in entry for c in "*?["):
                out += [entry] if entry not in out else []  # a name or a path: `scene_path` checks it
                continue
            matched = sorted(n for n in known if fnmatch.fnmatchcase(n, entry))
            if not matched:
                raise ConfigError(f"suite {self.name}: scenes: the pattern {entry!r} matches no shipped scene")
            out += [n for n in matched if n not in out]
        return out


def suite_dir(name: str) -> Path:
    """The directory of the suite `name` (a name under assets/suites, or a directory)."""
    path = Path(name)
    return path if path.is_dir() and (path / "suite.yaml").exists() else SUITES_DIR / name


def families_dir(name: str, suite: Suite) -> Path:
    """Where the family files of the suite `name` (a name under assets/suites, or a directory) are."""
    return FAMILIES_DIR if suite.family_dir is None else suite_dir(name) / suite.family_dir


def load_suite(name: str = DEFAULT_SUITE) -> Suite:
    """The manifest of the suite `name`; its families must exist."""
    path = suite_dir(name) / "suite.yaml"
    suite = load_yaml_model(path, Suite)
    if suite.family_dir is not None and not re.fullmatch(r"[A-Za-z0-9_\-]+", suite.family_dir):
        raise ConfigError(f"{path}: family_dir: a directory name beside suite.yaml, got {suite.family_dir!r}")
    families = load_families(families_dir(name, suite))
    missing = [f for f in suite.families if f not in families]
    if missing:
        raise ConfigError(f"{path}: families: no such family {missing} (known: {sorted(families)})")
    return suite


def parse_instances(text: str, where: str) -> list[Instance]:
    """The instances of a JSONL text; `ConfigError` names the line and the problem."""
    out: list[Instance] = []
    seen: set[str] = set()
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            instance = Instance.model_validate(json.loads(line))
        except json.JSONDecodeError as exc:
            raise ConfigError(f"{where}: line {number}: not JSON: {exc.msg}") from None
        except ValidationError as exc:
            raise ConfigError(f"{where}: line {number}: {validation_problems(exc)}") from None
        if instance.id in seen:
            raise ConfigError(f"{where}: line {number}: instance id {instance.id!r} is listed twice")
        seen.add(instance.id)
        out.append(instance)
    return out


#: The instance fields a split carries only when they are set (robocog-v1 predates them).
_OPTIONAL_FIELDS = ("capabilities", "observe", "perturbations")


def dump_instances(instances: list[Instance]) -> str:
    """Instances as JSONL: one compact line each, keys in schema order (byte-stable); the fields
    robocog-v1 predates only when set, and a perturbation's fields only when not at their default."""
    lines = []
    for i in instances:
        data = i.model_dump(mode="json", exclude={f for f in _OPTIONAL_FIELDS if not getattr(i, f)})
        if i.perturbations:
            data["perturbations"] = [p.model_dump(mode="json", exclude_defaults=True) for p in i.perturbations]
        lines.append(json.dumps(data, separators=(",", ":"), ensure_ascii=False) + "\n")
    return "".join(lines)


@cache
def _split(directory: Path, split: str) -> tuple[Instance, ...]:
    path = directory / f"{split}.jsonl"
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        if not directory.is_dir():
            known = sorted(p.name for p in SUITES_DIR.iterdir() if (p / "suite.yaml").exists())
            raise ConfigError(f"suite: no suite at {directory}; known suites: {', '.join(known)}") from None
        splits = sorted(p.stem for p in directory.glob("*.jsonl"))
        raise ConfigError(f"split: {path}: no such split; the splits of this suite: {', '.join(splits)}") from None
    return tuple(parse_instances(text, str(path)))


def load_split(suite: str = DEFAULT_SUITE, split: str = "dev") -> list[Instance]:
    """The instances of one split of a suite, in file order; a fresh split ("test@12345") from the
    cache of `robocog.shared.seeded_splits`, generated there first when it is missing."""
    directory = suite_dir(suite)
    if "@" in split and not (directory / f"{split}.jsonl").is_file():
        name, seed = parse_split(split)
        root = seeded_root(suite, name, seed if seed is not None else 0)  # "@" in split: a seed
        return list(_split(root / load_suite(suite).name, split))
    return list(_split(directory, split))


def fresh_split(suite: str, split: str) -> tuple[str, Path] | None:
    """A fresh split ("test@12345") of `suite` as its robot servers take it: the suite as reset_world
    names it ("SUITE@SEED") and the folder to start them with (`--splits`), generated first when it is
    missing; None for a split the suite ships."""
    name, seed = parse_split(split)
    if seed is None:
        return None
    return f"{load_suite(suite).name}@{seed}", seeded_root(suite, name, seed)


def seeded_root(suite: str, split: str, seed: int) -> Path:
    """The cache root holding the fresh split `split@seed` of `suite` (a name or a directory), generated
    first when it is missing (`robocog.shared.seeded_splits`)."""
    manifest = load_suite(suite)
    if split not in manifest.splits:
        raise ConfigError(f"suite {manifest.name} has no split {split!r} (its splits: {', '.join(manifest.splits)})")
    check_generable(manifest.splits[split].per_family, f"suite {manifest.name}: split {split}")
    root = root_for(suite_dir(suite))
    if not split_file(root, manifest.name, split, seed).is_file():
        generate_missing(suite, split, seed, root)
    return root


def find_seeded_instance(root: Path | None, suite: str, instance_id: str) -> tuple[Instance, bool]:
    """The instance `instance_id` of a fresh split (`suite` is "SUITE@SEED") under the cache root `root`
    the server was given (--splits), and whether look_around describes objects in that suite; a
    ValueError (bad input) when there is no root or no such instance."""
    match = SUITE_AT.fullmatch(suite)
    if match is None or int(match[2]) > MAX_SEED:
        raise ValueError(f"suite {suite[:80]!r}: a fresh split's suite is SUITE@SEED (SEED 0 to {MAX_SEED})")
    if root is None:
        raise ValueError(f"suite {suite!r} names a fresh split, and this server was started without --splits")
    directory = root / match[1]
    for path in sorted(directory.glob(f"*@{match[2]}.jsonl")):
        for instance in _split(directory, path.stem):
            if instance.id == instance_id:
                return instance, load_yaml_model(directory / "suite.yaml", Suite).describes_objects
    raise ValueError(f"no fresh split of {suite!r} under --splits holds an instance {instance_id!r}")


@cache
def describes_objects(suite: str) -> bool:
    """Whether look_around names the colour and size of what it shows during an instance of the shipped
    suite `suite` (robocog-v2.1 on)."""
    if not SUITE_NAME.fullmatch(suite):
        return False
    return load_yaml_model(SUITES_DIR / suite / "suite.yaml", Suite).describes_objects


def find_instance(suite: str, instance_id: str) -> Instance:
    """The instance `instance_id` of any split of the shipped suite `suite` (a name under
    assets/suites, never a path: the server looks instances up for its clients); a ValueError names
    what is known."""
    directory = SUITES_DIR / suite
    if not SUITE_NAME.fullmatch(suite) or not (directory / "suite.yaml").exists():
        known = sorted(p.name for p in SUITES_DIR.iterdir() if (p / "suite.yaml").exists())
        raise ValueError(f"unknown suite {suite!r}; known suites: {', '.join(known)}")
    splits = sorted(p.stem for p in directory.glob("*.jsonl"))
    for split in splits:
        for instance in _split(directory, split):
            if instance.id == instance_id:
                return instance
    raise ValueError(f"suite {suite!r} has no instance {instance_id!r} (splits: {', '.join(splits)})")


def select(instances: list[Instance], *, families: list[str] | None = None, limit: int | None = None) -> list[Instance]:
    """The instances of `families` (default: all), at most `limit` of them, spread over the families
    (round robin in file order), so a small sample still covers every family."""
    chosen = [i for i in instances if families is None or i.family in families]
    if limit is None or limit >= len(chosen):
        return chosen
    by_family: dict[str, list[Instance]] = {}
    for i in chosen:
        by_family.setdefault(i.family, []).append(i)
    out: list[Instance] = []
    queues = list(by_family.values())
    while len(out) < limit:
        for q in queues:
            if q and len(out) < limit:
                out.append(q.pop(0))
    return sorted(out, key=chosen.index)
