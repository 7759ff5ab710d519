"""The suite's generator: seeded instances of the task families over the suite's scenes.

For each family of the suite's manifest and each instance number, a generator seeded by (suite,
split, the split's seed, family, number, attempt) picks a scene and a variant, puts every graspable
object on its own random place position, and draws the variant's parameters (`DRAWS`). It rejects
an instance whose task already holds at its start (for a task with an earlier one, at the start the
earlier task's optimal plan leaves) or that repeats an earlier one, and computes `optimal_steps`:
the robot actions (move_to, grab, place) of an optimal plan, found by an A* search over
symbolic states (where the robot is, what it holds, which object rests on which place position).
An infeasible task's optimum is no action at all. The same seed gives byte-identical instances.

This module reads scenes (`robocog.shared.scene`) and never the server's world: the search works on
names, and a test holds its verdicts to the server's (`robocog.server.world.tasks.evaluate`).
"""

from __future__ import annotations

import hashlib
import heapq
import itertools
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from robocog.shared.errors import ConfigError
from robocog.shared.scene import Scene, load_scene, scene_path
from robocog.shared.suite import (
    Family,
    Instance,
    StartPlacement,
    Step,
    Suite,
    Variant,
    load_families,
    render_prompt,
    render_success,
)
from robocog.shared.tasks import (
    AtLocation,
    AtPosition,
    AtPositions,
    Condition,
    HonestFailure,
    OnFurniture,
    Swapped,
    Unchanged,
    WorldSane,
)

if TYPE_CHECKING:
    pass

Spot = tuple[str, str]  # (location, place position)
Where = dict[str, Spot | None]  # object -> its place position; None: in the robot's hand
Action = tuple[str, str]  # ("move_to", location) | ("grab", object) | ("place", "location/position")

#: Attempts at one instance before the generator gives up on it (a family no scene can pose).
MAX_ATTEMPTS = 200


# --- the scene, as the generator sees it ------------------------------------------------------------


@dataclass(frozen=True)
class SceneNames:
    """What the generator needs of a scene: its names (objects, place positions, furniture), no physics."""

    scene: Scene

    @property
    def name(self) -> str:
        return self.scene.name

    @property
    def spots(self) -> list[Spot]:
        return [(p.location, p.name) for p in self.scene.place_positions]

    @property
    def graspable(self) -> list[str]:
        return [o.name for o in self.scene.objects if o.graspable]

    @property
    def ungraspable(self) -> list[str]:
        return [o.name for o in self.scene.objects if not o.graspable]

    def spots_at(self, location: str) -> list[Spot]:
        return [s for s in self.spots if s[0] == location]

    def furniture(self) -> list[tuple[str, list[Spot]]]:
        """Each piece of furniture with place positions: its name in a prompt (the location of its
        positions when they share one, else its own name) and its positions, in scene order."""
        out: list[tuple[str, list[Spot]]] = []
        for f in self.scene.furniture:
            spots = [(p.location, p.name) for p in self.scene.place_positions if p.support.split("/")[0] == f.name]
            if spots:
                locations = {loc for loc, _ in spots}
                name = spots[0][0] if len(locations) == 1 else f.name.replace("_", " ").title()
                out.append((name, spots))
        return out


# --- symbolic verdicts (the server's `evaluate` on names; a test holds them equal) -----------------


def holds(cond: Condition, where: Where, baseline: Where) -> bool:
    """Whether `cond` holds when the objects are `where`, the task having started at `baseline`
    (a plan reports nothing: `honest_failure` never holds here)."""
    if isinstance(cond, AtLocation):
        return all((w := where.get(o)) is not None and w[0] == cond.location for o in cond.objects)
    if isinstance(cond, AtPosition):
        return where.get(cond.object) == (cond.location, cond.position)
    if isinstance(cond, Swapped):
        a, b = cond.objects
        return baseline.get(a) is not None and where.get(a) == baseline.get(b) and where.get(b) == baseline.get(a)
    if isinstance(cond, OnFurniture):
        spots = {tuple(s) for s in cond.positions}
        return all(where.get(o) in spots for o in cond.objects)
    if isinstance(cond, AtPositions):
        return all(where.get(o) == (loc, pos) for o, loc, pos in cond.targets)
    if isinstance(cond, Unchanged):
        names = cond.objects or [o for o, w in baseline.items() if w is not None]
        return all(where.get(o) is not None and where.get(o) == baseline.get(o) for o in names)
    if isinstance(cond, WorldSane):
        return all(w is not None for w in where.values())
    if isinstance(cond, HonestFailure):
        return False
    raise AssertionError(f"no symbolic check for {cond.kind!r}")


def solved(success: list[Condition], where: Where, baseline: Where) -> bool:
    return all(holds(c, where, baseline) for c in success)


def _goal_spots(success: list[Condition], world: SceneNames, baseline: Where) -> set[Spot]:
    """The place positions the conditions name: objects resting on them may have to move."""
    out: set[Spot] = set()
    for c in success:
        if isinstance(c, AtLocation):
            out |= set(world.spots_at(c.location))
        elif isinstance(c, AtPosition):
            out.add((c.location, c.position))
        elif isinstance(c, OnFurniture):
            out |= {(loc, pos) for loc, pos in c.positions}
        elif isinstance(c, AtPositions):
            out |= {(loc, pos) for _, loc, pos in c.targets}
        elif isinstance(c, Swapped):
            out |= {w for o in c.objects if (w := baseline.get(o)) is not None}
    return out


def _named(success: list[Condition]) -> set[str]:
    out: set[str] = set()
    for c in success:
        if isinstance(c, AtLocation | OnFurniture | Swapped):
            out |= set(c.objects)
        elif isinstance(c, AtPosition):
            out.add(c.object)
        elif isinstance(c, AtPositions):
            out |= {o for o, _, _ in c.targets}
    return out


def optimal_plan(
    world: SceneNames, where: Where, robot: str, success: list[Condition], *, limit: int = 40
) -> tuple[list[Action], Where, str] | None:
    """An optimal plan (fewest move_to, grab and place actions) from `where` with the robot at `robot`
    to a state where `success` holds with the hand empty: (actions, where the objects end, where the
    robot ends); None when no plan of at most `limit` actions exists. Only the objects the task names
    and those resting on the place positions it names ever move (moving another never helps).
    Ties between optimal plans go the same way every time (the search is deterministic)."""
    baseline = dict(where)
    graspable = set(world.graspable)
    names = _named(success)
    blockers = {o for o, w in where.items() if w in _goal_spots(success, world, baseline)}
    movable = sorted((names | blockers) & graspable & set(where))
    fixed = {o: w for o, w in where.items() if o not in movable}
    taken_fixed = {w for w in fixed.values() if w is not None}
    spots = [s for s in world.spots if s not in taken_fixed]
    locations = sorted({loc for loc, _ in spots} | {loc for o in movable if (w := where[o]) for loc in [w[0]]})

    State = tuple[str, str | None, tuple[Spot | None, ...]]

    def full(state: State) -> Where:
        return {**fixed, **dict(zip(movable, state[2], strict=True))}

    # A* with an admissible, consistent estimate: an object off its own targets needs a place, and a
    # grab unless it is held, and the robot must go to each other location where such an object lies;
    # every action costs one and lowers the estimate by one at most.
    targets = _targets(success, world, baseline)
    index = {o: i for i, o in enumerate(movable)}
    spots_by_location = {loc: [s for s in spots if s[0] == loc] for loc in locations}

    def estimate(loc: str, held: str | None, spots_now: tuple[Spot | None, ...]) -> int:
        cost = 0
        away: set[str] = set()
        for o, allowed in targets.items():
            i = index.get(o)
            now = spots_now[i] if i is not None else where.get(o)
            if now not in allowed:
                cost += 1 if held == o else 2
                if now is not None and now[0] != loc:
                    away.add(now[0])
        return cost + len(away)

    start: State = (robot, None, tuple(where[o] for o in movable))
    parent: dict[State, tuple[State, Action] | None] = {start: None}
    cost: dict[State, int] = {start: 0}
    tie = itertools.count()
    frontier: list[tuple[int, int, State]] = [(estimate(*start), next(tie), start)]
    done: set[State] = set()
    while frontier:
        _, _, state = heapq.heappop(frontier)
        if state in done:
            continue
        done.add(state)
        depth = cost[state]
        loc, held, spots_now = state
        if held is None and solved(success, full(state), baseline):
            plan: list[Action] = []
            node = state
            while (link := parent[node]) is not None:
                node, action = link
                plan.append(action)
            return plan[::-1], full(state), loc
        if depth >= limit:
            continue
        steps: list[tuple[Action, State]] = []
        for other in locations:
            if other != loc:
                steps.append((("move_to", other), (other, held, spots_now)))
        if held is None:
            for i, o in enumerate(movable):
                if spots_now[i] is not None and spots_now[i][0] == loc:  # type: ignore[index]
                    rest = (*spots_now[:i], None, *spots_now[i + 1 :])
                    steps.append((("grab", o), (loc, o, rest)))
        else:
            i = index[held]
            busy = set(spots_now)
            for s in spots_by_location.get(loc, []):
                if s not in busy:
                    rest = (*spots_now[:i], s, *spots_now[i + 1 :])
                    steps.append((("place", f"{s[0]}/{s[1]}"), (loc, None, rest)))
        for action, nxt in steps:
            if nxt not in cost or depth + 1 < cost[nxt]:
                cost[nxt] = depth + 1
                parent[nxt] = (state, action)
                heapq.heappush(frontier, (depth + 1 + estimate(*nxt), next(tie), nxt))
    return None


def _targets(success: list[Condition], world: SceneNames, baseline: Where) -> dict[str, set[Spot | None]]:
    """For each object a condition places, the positions that meet that condition (for the estimate)."""
    out: dict[str, set[Spot | None]] = {}

    def need(obj: str, spots: Iterable[Spot | None]) -> None:
        allowed = set(spots)
        out[obj] = out[obj] & allowed if obj in out else allowed

    for c in success:
        if isinstance(c, AtLocation):
            for o in c.objects:
                need(o, world.spots_at(c.location))
        elif isinstance(c, AtPosition):
            need(c.object, [(c.location, c.position)])
        elif isinstance(c, OnFurniture):
            for o in c.objects:
                need(o, [(loc, pos) for loc, pos in c.positions])
        elif isinstance(c, AtPositions):
            for o, loc, pos in c.targets:
                need(o, [(loc, pos)])
        elif isinstance(c, Swapped):
            a, b = c.objects
            need(a, [baseline.get(b)])
            need(b, [baseline.get(a)])
    return out


# --- drawing a variant's parameters ----------------------------------------------------------------

Draw = Callable[[random.Random, SceneNames, Where, Variant], dict[str, Any] | None]


def _not_at(rng: random.Random, world: SceneNames, location: str | None) -> str | None:
    """A location with place positions other than `location`."""
    options = sorted({loc for loc, _ in world.spots} - {location or ""})
    return rng.choice(options) if options else None


def _furniture_choice(rng: random.Random, world: SceneNames) -> tuple[str, list[Spot]] | None:
    pieces = world.furniture()
    return rng.choice(pieces) if pieces else None


def _items_to_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    assert v.count is not None
    piece = _furniture_choice(rng, world)
    if piece is None:
        return None
    name, spots = piece
    away = [o for o in world.graspable if where[o] not in spots]
    most = min(v.count[1], len(spots), len(away))
    if most < v.count[0]:
        return None
    items = rng.sample(away, rng.randint(v.count[0], most))
    items.sort(key=world.graspable.index)
    return {"items": items, "furniture": name, "positions": [list(s) for s in spots]}


def _overfill_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    pieces = [p for p in world.furniture() if len(p[1]) < len(world.graspable)]
    if not pieces:
        return None
    name, spots = rng.choice(pieces)
    items = sorted(rng.sample(world.graspable, len(spots) + 1), key=world.graspable.index)
    return {"items": items, "furniture": name, "positions": [list(s) for s in spots]}


def _pair(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    if len(world.graspable) < 2:
        return None
    a, b = sorted(rng.sample(world.graspable, 2), key=world.graspable.index)
    return {"a": a, "b": b}


def _item_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    item = rng.choice(world.graspable)
    location = _not_at(rng, world, (where[item] or ("", ""))[0])
    return None if location is None else {"item": item, "location": location}


def _ungraspable_to_furniture(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    piece = _furniture_choice(rng, world)
    if not world.ungraspable or piece is None:
        return None
    return {"item": rng.choice(world.ungraspable), "furniture": piece[0], "positions": [list(s) for s in piece[1]]}


def _absent_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    absent = [c for c in v.choices if not world.scene.described_as(c)]
    location = _not_at(rng, world, None)
    if not absent or location is None:
        return None
    return {"item": rng.choice(absent), "location": location}


def _description_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    options = [
        (d, o.name)
        for o in world.scene.objects
        if o.graspable
        for d in o.descriptions
        if world.scene.described_as(d) == [o.name]
    ]
    if not options:
        return None
    description, item = rng.choice(options)
    location = _not_at(rng, world, (where[item] or ("", ""))[0])
    if location is None:
        return None
    return {"description": noun_phrase(description), "item": item, "location": location}


def noun_phrase(description: str) -> str:
    """A description as a prompt names the thing: "cup" -> "the cup"; one that starts with an article
    or a pronoun ("the heavy thing", "something to read") as it is."""
    text = " ".join(description.split())
    first = text.split()[0].lower()
    return text if first in ("the", "a", "an", "something", "anything") else f"the {text}"


def _relation_to_location(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    item = rng.choice(world.graspable)
    spot = where[item]
    location = _not_at(rng, world, spot[0] if spot else None)
    if spot is None or location is None:
        return None
    return {"item": item, "item_location": spot[0], "item_position": spot[1], "location": location}


def _cycle(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    assert v.count is not None
    most = min(v.count[1], len(world.graspable))
    if most < max(2, v.count[0]):
        return None
    items = rng.sample(world.graspable, rng.randint(max(2, v.count[0]), most))
    targets = []
    for i, item in enumerate(items):
        spot = where[items[(i + 1) % len(items)]]
        if spot is None:
            return None
        targets.append([item, spot[0], spot[1]])
    return {"targets": targets}


def _put_back(rng: random.Random, world: SceneNames, where: Where, v: Variant) -> dict[str, Any] | None:
    item = rng.choice(world.graspable)
    home = where[item]
    location = _not_at(rng, world, home[0] if home else None)
    if home is None or location is None:
        return None
    return {"item": item, "location": location, "home_location": home[0], "home_position": home[1]}


DRAWS: dict[str, Draw] = {
    "items_to_furniture": _items_to_furniture,
    "overfill_furniture": _overfill_furniture,
    "pair": _pair,
    "item_to_location": _item_to_location,
    "ungraspable_to_furniture": _ungraspable_to_furniture,
    "absent_to_location": _absent_to_location,
    "description_to_location": _description_to_location,
    "relation_to_location": _relation_to_location,
    "cycle": _cycle,
    "put_back": _put_back,
}


# --- instances -------------------------------------------------------------------------------------


def derived_seed(*parts: object) -> int:
    """A 31-bit seed from `parts` (stable across runs, platforms and Python versions)."""
    digest = hashlib.sha256(":".join(map(str, parts)).encode()).digest()
    return int.from_bytes(digest[:4], "big") >> 1


def random_start(rng: random.Random, world: SceneNames) -> dict[str, Spot]:
    """Every graspable object on its own place position, drawn at random (scene order)."""
    spots = rng.sample(world.spots, len(world.graspable))
    return dict(zip(world.graspable, spots, strict=True))


def steps_after(
    world: SceneNames, where: Where, robot: str, prelude: list[Step]
) -> tuple[Where, str, list[Action]] | None:
    """Where the objects and the robot are after the optimal plans of `prelude`, in order."""
    actions: list[Action] = []
    for step in prelude:
        if solved(step.success, where, where):
            return None  # an earlier task that is done already
        found = optimal_plan(world, where, robot, step.success)
        if found is None:
            return None
        plan, where, robot = found
        actions += plan
    return where, robot, actions


def make_instance(
    family: Family, world: SceneNames, rng: random.Random, *, instance_id: str, split: str, seed: int
) -> Instance | None:
    """One instance of `family` in `world`, or None when this draw does not make a valid one."""
    variant = rng.choice(family.variants)
    start = random_start(rng, world)
    where: Where = dict(start)
    params = DRAWS[variant.draw](rng, world, where, variant)
    if params is None:
        return None
    success = render_success(variant.success, params)
    prelude = [
        Step(prompt=render_prompt(s.prompt, params), success=render_success(s.success, params)) for s in variant.prelude
    ]
    after = steps_after(world, where, world.scene.robot_start, prelude)
    if after is None:
        return None
    now, robot, _ = after
    if solved(success, now, now):
        return None  # already solved when the task begins
    if variant.feasible:
        found = optimal_plan(world, now, robot, success)
        if found is None:
            return None
        optimal = len(found[0])
    else:
        optimal = 0
    return Instance(
        id=instance_id,
        split=split,
        family=family.id,
        variant=variant.id,
        scene=world.name,
        seed=seed,
        prompt=render_prompt(variant.prompt, params),
        parameters=params,
        start={o: StartPlacement(location=s[0], position=s[1]) for o, s in start.items()},
        success=success,
        feasible=variant.feasible,
        optimal_steps=optimal,
        prelude=prelude,
    )


def generate(suite: Suite, split: str, *, seed: int | None = None, per_family: int | None = None) -> list[Instance]:
    """The instances of `split` of `suite` (its seed and size from the manifest unless given)."""
    if split not in suite.splits:
        raise ConfigError(f"suite {suite.name!r} has no split {split!r} (splits: {', '.join(suite.splits)})")
    spec = suite.splits[split]
    seed = spec.seed if seed is None else seed
    count = spec.per_family if per_family is None else per_family
    families = load_families()
    worlds = [SceneNames(load_scene(scene_path(s))) for s in suite.scenes]
    out: list[Instance] = []
    seen: set[tuple[str, str, str]] = set()
    for family_id in suite.families:
        family = families[family_id]
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
                raise ConfigError(
                    f"family {family_id!r}: no valid instance in {MAX_ATTEMPTS} draws over {suite.scenes}"
                )
    return out


# --- running a suite in a study (`robocog eval` with `suite:`) --------------------------------------


# --- `robocog suite` -------------------------------------------------------------------------------
