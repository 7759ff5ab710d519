"""The suite generator's planning problem: optimal plans over the names-only world.

A state is where the robot is, what it holds, which place position each object that may move rests
on and which containers are open; an action is a move_to, a grab, a place, an open or a close, each
costing one. Every container starts closed; a grab from or a place onto a position inside one needs it
open, and opening or closing needs the robot at its location with its hand free (as the server's
open and close tools do). A scene without containers never meets the last two. Conditions are read through
their symbolic meaning (`robocog.shared.tasks`), and plans are found by the one A* search
(`robocog.agent.symbolic.search`), so "optimal" means what it means there: the fewest robot actions.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Sequence

from robocog.agent.symbolic.bounds import carrying_drives
from robocog.agent.symbolic.search import Cost, Problem, astar
from robocog.agent.symbolic.world import Action, SceneNames, Spot, Where
from robocog.shared.suite import Step
from robocog.shared.tasks import Allowed, Closed, Condition

#: The longest plan the generator looks for (no suite task needs as many actions).
PLAN_LIMIT = 40
#: The most states the generator expands looking for one plan: beyond it the draw is given up (and
#: drawn again) rather than searched through every plan of up to `PLAN_LIMIT` actions, which a task
#: with no plan at all (a target the arm cannot reach) would take hours to prove.
EXPANSION_LIMIT = 300_000

#: the robot's location, what it holds, each mover's spot, the open containers
State = tuple[str, str | None, tuple[Spot | None, ...], frozenset[str]]
STEP: Cost = (1,)


def holds(cond: Condition, where: Where, baseline: Where, opened: Collection[str] = ()) -> bool:
    """Whether `cond` holds when the objects are `where` and the containers `opened` open, the task
    having started at `baseline` (a plan reports nothing: `honest_failure` never holds here)."""
    return cond.holds(where, baseline, None, opened)


def solved(success: Sequence[Condition], where: Where, baseline: Where, opened: Collection[str] = ()) -> bool:
    """Whether every condition of `success` holds."""
    return all(c.holds(where, baseline, None, opened) for c in success)


def allowed_spots(success: Sequence[Condition], spots: Sequence[Spot], baseline: Where) -> Allowed:
    """For each object the conditions place, the positions that meet all of them."""
    out: Allowed = {}
    for cond in success:
        for obj, allowed in cond.allowed_spots(spots, baseline).items():
            out[obj] = out[obj] & allowed if obj in out else allowed
    return out


def optimal_plan(
    world: SceneNames, where: Where, robot: str, success: list[Condition], *, limit: int = PLAN_LIMIT
) -> tuple[list[Action], Where, str] | None:
    """An optimal plan (fewest move_to, grab, place, open and close actions) from `where` with the
    robot at `robot`, every container closed, to a state where `success` holds with the hand empty:
    (actions, where the objects end, where the robot ends); None when no plan of at most `limit`
    actions exists. Only the objects the task names and those resting on the place positions it
    names ever move (moving another never helps).
    Ties between optimal plans go the same way every time (the search is deterministic)."""
    baseline = dict(where)
    names = {o for c in success for o in c.objects_named()}
    named_spots = {s for c in success for s in c.named_spots(world.spots, baseline)}
    blockers = {o for o, w in where.items() if w in named_spots}
    movable = sorted((names | blockers) & set(world.graspable) & set(where))
    fixed = {o: w for o, w in where.items() if o not in movable}
    taken_fixed = {w for w in fixed.values() if w is not None}
    spots = [s for s in world.spots if s not in taken_fixed]
    locations = sorted({loc for loc, _ in spots} | {loc for o in movable if (w := where[o]) for loc in [w[0]]})
    spots_by_location = {loc: [s for s in spots if s[0] == loc] for loc in locations}
    targets = allowed_spots(success, world.spots, baseline)
    index = {o: i for i, o in enumerate(movable)}
    inside = world.inside
    boxes_at = {loc: sorted(b for b, at in world.containers.items() if at == loc) for loc in locations}
    to_close = sorted({b for c in success if isinstance(c, Closed) for b in c.containers})

    def reachable(spot: Spot | None, opened: frozenset[str]) -> bool:
        box = inside.get(spot) if spot is not None else None
        return box is None or box in opened

    def full(state: State) -> Where:
        return {**fixed, **dict(zip(movable, state[2], strict=True))}

    # The one location each object's targets lie at, where they share one (a place there is needed).
    target_at: dict[str, str] = {}
    for o, allowed in targets.items():
        if len(locations_of := {s[0] for s in allowed if s}) == 1:
            target_at[o] = locations_of.pop()

    def estimate(state: State) -> Cost:
        # Admissible: an object off its own targets needs a place, and a grab unless it is held; a
        # container left open that must end closed needs a close; the robot must reach every other
        # location where such an object lies or where its targets all lie, and carry each object
        # whose targets all lie elsewhere there (`carrying_drives`). Every action costs one.
        loc, held, spots_now, opened = state
        cost = sum(1 for b in to_close if b in opened)
        away: set[str] = set()
        edges: list[tuple[str, str]] = []
        for o, allowed in targets.items():
            i = index.get(o)
            now = spots_now[i] if i is not None else where.get(o)
            if now in allowed:
                continue
            cost += 1 if held == o else 2
            at = loc if now is None else now[0]
            if now is not None:
                away.add(at)
            goal = target_at.get(o)
            if goal is not None:
                away.add(goal)
                edges.append((at, goal))
        return (cost + max(len(away - {loc}), carrying_drives(edges, loc)),)

    def successors(state: State) -> Iterator[tuple[Action, State, Cost]]:
        loc, held, spots_now, opened = state
        for other in locations:
            if other != loc:
                yield ("move_to", other), (other, held, spots_now, opened), STEP
        if held is None:
            for i, o in enumerate(movable):
                spot = spots_now[i]
                if spot is not None and spot[0] == loc and reachable(spot, opened):
                    yield ("grab", o), (loc, o, (*spots_now[:i], None, *spots_now[i + 1 :]), opened), STEP
            for box in boxes_at.get(loc, []):
                if box in opened:
                    yield ("close", box), (loc, None, spots_now, opened - {box}), STEP
                else:
                    yield ("open", box), (loc, None, spots_now, opened | {box}), STEP
        else:
            i = index[held]
            busy = set(spots_now)
            for s in spots_by_location.get(loc, []):
                if s not in busy and reachable(s, opened):
                    put = (*spots_now[:i], s, *spots_now[i + 1 :])
                    yield ("place", f"{s[0]}/{s[1]}"), (loc, None, put, opened), STEP

    def is_goal(state: State) -> bool:
        return state[1] is None and solved(success, full(state), baseline, state[3])

    start: State = (robot, None, tuple(where[o] for o in movable), frozenset())
    found = astar(
        Problem(start, successors, is_goal, estimate),
        action_limit=limit,
        expansion_limit=EXPANSION_LIMIT,
        deeper_first=True,
    )
    if found is None:
        return None
    return found.actions, full(found.state), found.state[0]


def steps_after(
    world: SceneNames, where: Where, robot: str, prelude: list[Step]
) -> tuple[Where, str, list[Action]] | None:
    """Where the objects and the robot are after the optimal plans of `prelude`, in order (None when
    an earlier task is done already or cannot be done), and the actions of those plans."""
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
