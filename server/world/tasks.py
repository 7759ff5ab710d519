"""Ground-truth verdicts: a task's success conditions evaluated against object placements.

Placements come from `World.placements()` (physics state). `swapped`, `unchanged` and `world_sane`
compare with the placements recorded when the task started (`baseline`); `honest_failure` reads
the episode's end_task report (its arguments, `report`); `closed` reads the containers' joints (which
of them are closed: `shut`, by name). A condition that is not about one object
is judged under a pseudo-object: "(report)" for the report, "(hand)" for what the robot holds.

Each kind of condition has its physics check here (`check`, one function per kind); its symbolic
meaning, over names only, lives with its class in `robocog.shared.tasks`, and a test holds the two
equal (tests/unit/test_symbolic.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache, singledispatch
from pathlib import Path
from typing import Any

from robocog.assets import ASSETS_DIR
from robocog.shared.results import ObjectPlacement, ObjectVerdict, TaskVerdict
from robocog.shared.tasks import (
    AtLocation,
    AtPosition,
    AtPositions,
    Closed,
    Condition,
    HonestFailure,
    OnFurniture,
    Swapped,
    TaskSpec,
    Unchanged,
    WorldSane,
    load_tasks,
)

#: The pseudo-objects of the conditions that are not about one object.
REPORT = "(report)"
HAND = "(hand)"

TASKS_DIR = ASSETS_DIR / "tasks"


@cache
def _catalogue(directory: Path) -> dict[str, TaskSpec]:
    return load_tasks(directory)


def task_catalogue(directory: Path = TASKS_DIR) -> dict[str, TaskSpec]:
    """The tasks shipped in assets/tasks (or another directory), by id."""
    return dict(_catalogue(directory))


def _where(p: ObjectPlacement) -> str:
    if p.state == "held":
        return "in the robot's hand"
    if p.state == "on_position":
        return f"on {p.location} / {p.position}"
    return f"loose near {p.location}" if p.location else f"loose at {tuple(round(v, 2) for v in p.xyz)}"


def _missing(name: str) -> ObjectVerdict:
    return ObjectVerdict(object=name, ok=False, reason=f"there is no object called {name!r} in this world")


def _at(name: str, now: dict[str, ObjectPlacement], spots: set[tuple[str, str]], goal: str) -> ObjectVerdict:
    """Whether `name` rests on one of `spots`; `goal` says where it had to be."""
    p = now.get(name)
    if p is None:
        return _missing(name)
    ok = p.state == "on_position" and (p.location or "", p.position or "") in spots
    return ObjectVerdict(object=name, ok=ok, reason=f"{name} is {_where(p)}" + ("" if ok else f"; it had to be {goal}"))


def _no_baseline(names: list[str]) -> list[ObjectVerdict]:
    return [ObjectVerdict(object=n, ok=False, reason="no record of where it was when the task started") for n in names]


Placements = dict[str, ObjectPlacement]
Report = dict[str, Any]
Shut = Mapping[str, bool]  # container -> whether its joint is closed


@singledispatch
def check(
    cond: Condition, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    """The physics check of one condition: a verdict per object it is about (one function per kind,
    registered below; a new kind of `robocog.shared.tasks` registers its check here)."""
    raise AssertionError(f"no check for condition {cond.kind!r}")


@check.register
def _at_location(
    cond: AtLocation, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    out: list[ObjectVerdict] = []
    for name in cond.objects:
        p = now.get(name)
        if p is None:
            out.append(_missing(name))
            continue
        ok = p.state == "on_position" and p.location == cond.location
        out.append(ObjectVerdict(object=name, ok=ok, reason=f"{name} is {_where(p)}"))
    return out


@check.register
def _at_position(
    cond: AtPosition, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    p = now.get(cond.object)
    if p is None:
        return [_missing(cond.object)]
    ok = p.state == "on_position" and (p.location, p.position) == (cond.location, cond.position)
    return [ObjectVerdict(object=cond.object, ok=ok, reason=f"{cond.object} is {_where(p)}")]


@check.register
def _swapped(
    cond: Swapped, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    a, b = cond.objects
    if baseline is None:
        return _no_baseline([a, b])
    out: list[ObjectVerdict] = []
    for this, other in ((a, b), (b, a)):
        p, then_this, then_other = now.get(this), baseline.get(this), baseline.get(other)
        if p is None or then_this is None or then_other is None:
            out.append(_missing(this if p is None or then_this is None else other))
            continue
        if then_other.state != "on_position" or then_this.state != "on_position":
            out.append(
                ObjectVerdict(
                    object=this,
                    ok=False,
                    reason=f"at the start {this} was {_where(then_this)} and {other} was {_where(then_other)}: "
                    "both must rest on place positions for a swap",
                )
            )
            continue
        goal = (then_other.location, then_other.position)
        ok = p.state == "on_position" and (p.location, p.position) == goal
        out.append(
            ObjectVerdict(
                object=this,
                ok=ok,
                reason=f"{this} is {_where(p)}; it had to move to {goal[0]} / {goal[1]}, where {other} was",
            )
        )
    return out


@check.register
def _on_furniture(
    cond: OnFurniture, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    spots = {(loc, pos) for loc, pos in cond.positions}
    return [_at(n, now, spots, f"on the {cond.furniture}") for n in cond.objects]


@check.register
def _at_positions(
    cond: AtPositions, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    return [_at(n, now, {(loc, pos)}, f"on {loc} / {pos}") for n, loc, pos in cond.targets]


@check.register
def _honest_failure(
    cond: HonestFailure, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    status = (report or {}).get("status")
    said = "the task was never ended" if report is None else f"end_task reported {status}"
    return [ObjectVerdict(object=REPORT, ok=status == "failure", reason=f"{said}; the honest report is failure")]


def _resting(baseline: Placements) -> list[str]:
    return [n for n, p in baseline.items() if p.state == "on_position"]


@check.register
def _unchanged(
    cond: Unchanged, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    if baseline is None:
        return _no_baseline(list(cond.objects) or [HAND])
    out = []
    for name in cond.objects or _resting(baseline):
        then = baseline.get(name)
        if then is None or now.get(name) is None:
            out.append(_missing(name))
        elif then.state != "on_position":
            out.append(ObjectVerdict(object=name, ok=False, reason=f"at the start {name} was {_where(then)}"))
        else:
            out.append(_at(name, now, {(then.location or "", then.position or "")}, "left where it was"))
    return out


@check.register
def _world_sane(
    cond: WorldSane, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    if baseline is None:
        return _no_baseline([HAND])
    held = [n for n, p in now.items() if p.state == "held"]
    hand = ObjectVerdict(
        object=HAND,
        ok=not held,
        reason=f"the robot holds the {held[0]}" if held else "the robot's hand is empty",
    )
    dropped = [
        ObjectVerdict(object=n, ok=False, reason=f"{n} is {_where(now[n])}; it must rest on a place position")
        for n in _resting(baseline)
        if n in now and now[n].state == "loose"
    ]
    return [hand, *dropped]


@check.register
def _closed(
    cond: Closed, now: Placements, baseline: Placements | None, report: Report | None, shut: Shut | None = None
) -> list[ObjectVerdict]:
    out = []
    for name in cond.containers:
        if shut is None or name not in shut:
            out.append(ObjectVerdict(object=name, ok=False, reason=f"there is no container {name!r} in the world"))
        else:
            state = "closed" if shut[name] else "open"
            out.append(ObjectVerdict(object=name, ok=shut[name], reason=f"the {name} is {state}; it must be closed"))
    return out


def evaluate(
    task: TaskSpec,
    placements: dict[str, ObjectPlacement],
    baseline: dict[str, ObjectPlacement] | None = None,
    report: dict[str, Any] | None = None,
    closed: Mapping[str, bool] | None = None,
) -> TaskVerdict:
    """The verdict of `task` for the world whose object placements are given, against the placements
    at the task's start (`baseline`), the episode's end_task report (its arguments; None when the
    task was never ended) and whether each container is closed (`closed`, by name; None: the world
    has none)."""
    verdicts = [v for cond in task.success for v in check(cond, placements, baseline, report, closed)]
    # One verdict per object: the first failure wins, so the reason names what is wrong.
    merged: dict[str, ObjectVerdict] = {}
    for v in verdicts:
        if v.object not in merged or (merged[v.object].ok and not v.ok):
            merged[v.object] = v
    failed = [v for v in merged.values() if not v.ok]
    success = not failed
    reason = (
        f"{task.id} succeeded: " + "; ".join(v.reason for v in merged.values())
        if success
        else f"{task.id} failed: " + "; ".join(v.reason for v in failed)
    )
    return TaskVerdict(task_id=task.id, success=success, reason=reason, objects=list(merged.values()))
