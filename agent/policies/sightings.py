"""How the planner's belief takes in what it sees when a look around does not show everything: under
partial observation (look_around shows the robot's own location only, `observed` set) each look adds
to what earlier ones showed instead of replacing it, and what the robot knows is shut inside a closed
container (it put it there, or saw it when it opened it) stays believed there, though no look shows it.

So the belief is the planner's memory of the house within an episode: the map grows with every
location visited (a location's neighbours are known once it has been seen), and the search for an
object (`robocog.agent.policies.explore`) knows which locations and containers it has not seen yet.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robocog.agent.families.reading import Goal
from robocog.agent.policies.belief import Belief


def closed_over(result: dict[str, Any]) -> str | None:
    """The closed container a failed grab's or place's result names in the way (its `container`), if any."""
    container = result.get("container") if result.get("status") == "failure" else None
    return container if isinstance(container, str) else None


def out_of_sight(goals: Mapping[str, Goal], first: Belief) -> bool:
    """Whether the goals name an object or a location the first look did not show."""
    seen = set(first.objects())
    return any(o not in seen for o in goals) or any(g.location not in first.seen for g in goals.values())


def merge(old: Belief, look: dict[str, Any], new: Belief | None = None) -> Belief:
    """The belief after `look` (a look_around result), from the belief `old` before it. `new`: what
    `look` shows (`Belief.from_look(look)`, a belief of its own), when it has been read already."""
    new = type(old).from_look(look) if new is None else new
    looked = set(new.seen)
    if look.get("observed"):  # only part of the house: the rest is as it was last seen
        new = _over(old, new)
    _keep_shut_in(old, new)
    new.first_seen = old.first_seen | {o: w for o, w in new.where.items() if o not in old.first_seen}
    gone = [o for o, (loc, _) in old.where.items() if loc in looked and o not in new.where and o != new.holding]
    # Something is not where it was seen: it may be anywhere, the places seen before too (`vanished`).
    new.recheck = ((old.seen | old.recheck) if gone else old.recheck) - looked
    return new


def vanished(belief: Belief, name: str, result: dict[str, Any]) -> None:
    """After news that the world changed, or a grab that found nothing where the object was believed
    to be, every place seen so far may hold what moved: the search looks at them again (`recheck`)."""
    lost = name == "grab" and result.get("error") == "out_of_reach"
    if lost or "Something changed:" in str(result.get("message", "")):
        belief.recheck = set(belief.seen)


def _over(old: Belief, new: Belief) -> Belief:
    """`old` with the locations `new` saw replaced by what it saw there."""
    out = old.copy()
    out.location, out.holding, out.stale = new.location, new.holding, False
    for loc in new.seen:
        out.neighbours[loc] = new.neighbours.get(loc, [])
        for p in out.positions.get(loc, []):
            out.occupant.pop((loc, p), None)
        out.positions[loc] = new.positions.get(loc, [])
        out.occupant.update({k: v for k, v in new.occupant.items() if k[0] == loc})
        for obj in [o for o, w in out.where.items() if w[0] == loc]:
            del out.where[obj]
    for obj, spot in new.where.items():
        out.where[obj] = spot
    if out.holding is not None:
        out.where.pop(out.holding, None)
    out.containers.update(new.containers)
    out.looks.update(new.looks)
    seen_boxes = {b for b, loc in new.containers.items() if loc in new.seen}
    out.closed = (out.closed - seen_boxes) | (new.closed & seen_boxes)
    out.seen |= new.seen
    return out


def _keep_shut_in(old: Belief, new: Belief) -> None:
    """Objects `old` believed inside a container that is closed now, and that `new` sees nowhere else,
    are still inside it (a closed container hides what it holds)."""
    shut = {new.containers[b] for b in new.closed if b in new.containers}
    for obj, (loc, position) in old.where.items():
        if loc in shut and position and obj not in new.where and obj != new.holding:
            new.where[obj] = (loc, position)
            new.occupant[(loc, position)] = obj


def operated(belief: Belief, result: dict[str, Any], *, opened: bool) -> None:
    """Take in an open or close result: the container's state, and (opened) a look inside to come."""
    name = result.get("furniture")
    if result.get("status") != "success" or not name:
        return
    if result.get("state", "open" if opened else "closed") == "closed":
        belief.closed.add(name)
    else:
        belief.closed.discard(name)
        belief.stale = True  # what is inside shows on the next look around
