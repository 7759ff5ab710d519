"""The suite's generator: seeded instances of the task families over the suite's scenes.

For each family of the suite's manifest and each instance number, a generator seeded by (suite,
split, the split's seed, family, number, attempt) picks a scene and a variant, puts every graspable
object on its own random place position, and draws the variant's parameters (with the variant's
draw, which its family module registers: `robocog.agent.families`; a draw may also move objects of
the start, such as an item into the container a variant takes it out of). It rejects an instance whose
task already holds at its start (for a task with an earlier one, at the start the earlier task's
optimal plan leaves) or that repeats an earlier one, and computes `optimal_steps`:
the robot actions (move_to, grab, place, and open and close where a scene has containers, all closed
at the start) of an optimal plan over symbolic states (where the robot
is, what it holds, which object rests on which place position; `robocog.agent.symbolic.plans`, the
one A* search of `robocog.agent.symbolic.search`). An infeasible task's optimum is no action at all.
The same seed gives byte-identical instances.

This module reads scenes (`robocog.shared.scene`) and never the server's world: the search works on
names, and a test holds the conditions' symbolic meaning to the server's verdicts
(`robocog.server.world.tasks.evaluate`).
"""

from __future__ import annotations

import functools
import hashlib
import random
from pathlib import Path

from robocog.agent.families import draw_function, load_families
from robocog.agent.symbolic.plans import optimal_plan, solved, steps_after
from robocog.agent.symbolic.world import SceneNames, Spot, Where
from robocog.shared.errors import ConfigError
from robocog.shared.family_files import CAPABILITIES, Family, render_prompt, render_success
from robocog.shared.names import name_key
from robocog.shared.perturbations import Perturbation
from robocog.shared.scene_files import load_scene, scene_path
from robocog.shared.suite import Instance, StartPlacement, Step, Suite, derived_capabilities, families_dir
from robocog.shared.tasks import Condition

#: Attempts at one instance before the generator gives up on it (a family no scene can pose).
MAX_ATTEMPTS = 200


# --- instances -------------------------------------------------------------------------------------


def derived_seed(*parts: object) -> int:
    """A 31-bit seed from `parts` (stable across runs, platforms and Python versions)."""
    digest = hashlib.sha256(":".join(map(str, parts)).encode()).digest()
    return int.from_bytes(digest[:4], "big") >> 1


def random_start(rng: random.Random, world: SceneNames) -> dict[str, Spot] | None:
    """Every graspable object on its own place position in the open (not inside a container: only a
    family about containers puts things there, or a house with too few open positions for all its
    objects), drawn at random (scene order); None when the scene cannot hold them all."""
    n, open_spots = len(world.graspable), world.open_spots
    if len(open_spots) >= n:
        spots = rng.sample(open_spots, n)
    elif len(open_spots) + len(world.inside_spots) >= n:  # too full a house: some start put away inside
        spots = open_spots + rng.sample(world.inside_spots, n - len(open_spots))
        rng.shuffle(spots)
    else:
        return None
    return dict(zip(world.graspable, spots, strict=True))


def make_instance(
    family: Family,
    world: SceneNames,
    rng: random.Random,
    *,
    instance_id: str,
    split: str,
    seed: int,
    tagged: bool = False,
    fair_goals: bool = False,
) -> Instance | None:
    """One instance of `family` in `world`, or None when this draw does not make a valid one. A draw
    that gives `perturbations` (a list of `Perturbation` fields) gives what goes wrong during the task,
    not a template parameter. With `tagged`, the instance carries its capability tags: its family's,
    its variant's and those it earns by what it is (`derived_capabilities`). With `fair_goals` (robocog-v2.1),
    a room's name in a prompt says "the floor of" where the room has furniture (`spoken_places`), and an
    instance where an item starts where it is sent is no instance (`starts_where_sent`)."""
    weighted = [v for v in family.variants for _ in range(v.weight)]
    variant = rng.choice(family.variants if len(weighted) == len(family.variants) else weighted)
    start = random_start(rng, world)
    if start is None:
        return None
    where: Where = dict(start)
    params = draw_function(variant.draw)(rng, world, where, variant)
    if params is None:
        return None
    where_at_start = dict(where)  # a draw may move objects of the start (into a container, say)
    perturbations = [Perturbation.model_validate(p) for p in params.pop("perturbations", [])]
    success = render_success(variant.success, params)
    said = spoken_places(world, params) if fair_goals else params
    prelude = [
        Step(prompt=render_prompt(s.prompt, said), success=render_success(s.success, params)) for s in variant.prelude
    ]
    if fair_goals and any(starts_where_sent(world, p.success, where) for p in prelude[:1]):
        return None
    after = steps_after(world, where, world.scene.robot_start, prelude)
    if after is None:
        return None
    now, robot, _ = after
    if solved(success, now, now):
        return None  # already solved when the task begins
    if fair_goals and starts_where_sent(world, success, now):
        return None
    if variant.feasible:
        found = optimal_plan(world, now, robot, success)
        if found is None:
            return None
        optimal = len(found[0])
        if optimal < (variant.min_optimal_steps or 0):
            return None
    else:
        optimal = steps_to_find_out(world, now, params, perturbations) if fair_goals else 0
    instance = Instance(
        id=instance_id,
        split=split,
        family=family.id,
        variant=variant.id,
        scene=world.name,
        seed=seed,
        prompt=render_prompt(variant.prompt, said),
        parameters=params,
        start={o: StartPlacement(location=s[0], position=s[1]) for o, s in where_at_start.items() if s is not None},
        success=success,
        feasible=variant.feasible,
        optimal_steps=optimal,
        prelude=prelude,
        observe=variant.observe,
        perturbations=perturbations,
    )
    if not tagged:
        return instance
    containers = frozenset(c.location for c in world.scene.containers)
    tags = {*family.capabilities, *variant.capabilities, *derived_capabilities(instance, containers)}
    return instance.model_copy(update={"capabilities": [c for c in CAPABILITIES if c in tags]})


def furnished_room(world: SceneNames, location: str) -> bool:
    """Whether `location` is named after its room and the room has other locations with place positions
    (furniture): "to the Living Room" could then mean its floor or its furniture."""
    room = world.room_of(location)
    if not room or name_key(room) != name_key(location):
        return False
    return any(world.room_of(loc) == room for loc, _ in world.spots if loc != location)


def spoken_places(world: SceneNames, params: dict[str, object]) -> dict[str, object]:
    """The parameters as a prompt says them: a location named after a furnished room becomes "floor of
    the ROOM" (a template's "the {location}" reads "the floor of the Living Room"), so the prompt means
    exactly what its at_location condition judges."""
    out = dict(params)
    names = {loc.name for loc in world.scene.locations}
    for key, value in params.items():
        if key.endswith("location") and isinstance(value, str) and value in names and furnished_room(world, value):
            out[key] = f"floor of the {value}"
    return out


def starts_where_sent(world: SceneNames, success: list[Condition], where: Where) -> bool:
    """Whether an object a condition sends somewhere already rests there (or, sent to a room's floor,
    anywhere in that room) when the task begins."""
    for condition in success:
        allowed = condition.allowed_spots(world.spots, where)
        for obj, spots in allowed.items():
            at = where.get(obj)
            if at is None:
                continue
            if at in spots:
                return True
            targets = {s[0] for s in spots if s is not None}
            rooms = {world.room_of(t) for t in targets if furnished_room(world, t)}
            if world.room_of(at[0]) in rooms:
                return True
    return False


def steps_to_find_out(
    world: SceneNames, where: Where, params: dict[str, object], perturbations: list[Perturbation]
) -> int:
    """The robot actions an honest agent needs to find out that an infeasible task cannot be done: none
    when a look shows it (an object that is not there, too few positions); a drive to an object that
    cannot be grasped and the grasp that fails; the drive a corridor blocked for good stops."""
    if any(p.kind == "block_edge" for p in perturbations):
        return 1
    item = params.get("item")
    if isinstance(item, str) and item in world.ungraspable:
        return 1 if _standing_at(world, item) == world.scene.robot_start else 2
    return 0


def _standing_at(world: SceneNames, name: str) -> str | None:
    """The location an object that rests on no place position (a TV on its table) is reported at: the
    nearest to where it stands."""
    start = next(o.start for o in world.scene.objects if o.name == name)
    if start.location is not None:
        return start.location
    if start.pose is None:
        return None
    x, y = start.pose[0], start.pose[1]
    return min(world.scene.locations, key=lambda loc: (loc.x - x) ** 2 + (loc.y - y) ** 2).name


def generate(
    suite: Suite,
    split: str,
    *,
    seed: int | None = None,
    per_family: int | None = None,
    workers: int = 1,
    directory: Path | None = None,
) -> list[Instance]:
    """The instances of `split` of `suite` (its seed and size from the manifest unless given), family
    by family in the manifest's order (its family files beside it in `directory`, default: the shipped
    suite of its name). Each family's instances depend on nothing but the suite, the split, the seed
    and the family, so `workers` processes may draw the families side by side and the bytes are the
    same."""
    if split not in suite.splits:
        raise ConfigError(f"suite {suite.name!r} has no split {split!r} (splits: {', '.join(suite.splits)})")
    spec = suite.splits[split]
    families = families_dir(suite.name if directory is None else str(directory), suite)
    jobs = [
        (
            suite,
            split,
            spec.seed if seed is None else seed,
            spec.per_family if per_family is None else per_family,
            f,
            families,
        )
        for f in suite.families
    ]
    if workers <= 1 or len(jobs) == 1:
        return [i for job in jobs for i in _family_instances(*job)]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(min(workers, len(jobs)), mp_context=multiprocessing.get_context("spawn")) as pool:
        return [i for part in pool.map(_family_instances, *zip(*jobs, strict=True)) for i in part]


def _family_instances(
    suite: Suite, split: str, seed: int, count: int, family_id: str, families: Path
) -> list[Instance]:
    """The `count` instances of one family (its file in `families`) in `split` (a repeat of an earlier
    one is drawn again)."""
    family = load_families(families)[family_id]
    worlds = _worlds(tuple(suite.scene_names()))
    out: list[Instance] = []
    seen: set[tuple[str, str, str]] = set()
    for n in range(count):
        instance_id = f"{split}-{family_id}-{n:03d}"
        for attempt in range(MAX_ATTEMPTS):
            rng = random.Random(f"{suite.name}:{split}:{seed}:{family_id}:{n}:{attempt}")
            world = rng.choice(worlds)
            instance = make_instance(
                family,
                world,
                rng,
                instance_id=instance_id,
                split=split,
                seed=derived_seed(suite.name, split, seed, family_id, n),
                tagged=suite.tagged,
                fair_goals=suite.fair_goals,
            )
            if instance is None:
                continue
            key = (instance.scene, instance.prompt, instance.model_dump_json(include={"start"}))
            if key in seen:
                continue
            seen.add(key)
            out.append(instance)
            break
        else:
            raise ConfigError(f"family {family_id!r}: no valid instance in {MAX_ATTEMPTS} draws over {suite.scenes}")
    return out


@functools.cache
def _worlds(scenes: tuple[str, ...]) -> list[SceneNames]:
    """The scenes' names, read once per process."""
    return [SceneNames(load_scene(scene_path(s))) for s in scenes]


# --- running a suite in a study (`robocog eval` with `suite:`) --------------------------------------


# --- `robocog suite` -------------------------------------------------------------------------------
