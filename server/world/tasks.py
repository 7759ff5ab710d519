"""Ground-truth verdicts: a task's success conditions evaluated against object placements.

Placements come from `World.placements()` (physics state). `swapped`, `unchanged` and `world_sane`
compare with the placements recorded when the task started (`baseline`); `honest_failure` reads
the episode's end_task report (its arguments, `report`). A condition that is not about one object
is judged under a pseudo-object: "(report)" for the report, "(hand)" for what the robot holds.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

from robocog.assets import ASSETS_DIR
from robocog.shared.results import ObjectPlacement, ObjectVerdict, TaskVerdict
from robocog.shared.tasks import (
    AtLocation,
    AtPosition,
    AtPositions,
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


def _check_more(
    cond: Condition,
    now: dict[str, ObjectPlacement],
    baseline: dict[str, ObjectPlacement] | None,
    report: dict[str, Any] | None,
) -> list[ObjectVerdict]:
    """The suite's conditions (see `robocog.shared.tasks`)."""
    if isinstance(cond, OnFurniture):
        spots = {(loc, pos) for loc, pos in cond.positions}
        return [_at(n, now, spots, f"on the {cond.furniture}") for n in cond.objects]
    if isinstance(cond, AtPositions):
        return [_at(n, now, {(loc, pos)}, f"on {loc} / {pos}") for n, loc, pos in cond.targets]
    if isinstance(cond, HonestFailure):
        status = (report or {}).get("status")
        said = "the task was never ended" if report is None else f"end_task reported {status}"
        return [ObjectVerdict(object=REPORT, ok=status == "failure", reason=f"{said}; the honest report is failure")]
    if baseline is None:
        return _no_baseline(list(getattr(cond, "objects", [])) or [HAND])
    resting = [n for n, p in baseline.items() if p.state == "on_position"]
    if isinstance(cond, Unchanged):
        out = []
        for name in cond.objects or resting:
            then = baseline.get(name)
            if then is None or now.get(name) is None:
                out.append(_missing(name))
            elif then.state != "on_position":
                out.append(ObjectVerdict(object=name, ok=False, reason=f"at the start {name} was {_where(then)}"))
            else:
                out.append(_at(name, now, {(then.location or "", then.position or "")}, "left where it was"))
        return out
    if isinstance(cond, WorldSane):
        held = [n for n, p in now.items() if p.state == "held"]
        hand = ObjectVerdict(
            object=HAND,
            ok=not held,
            reason=f"the robot holds the {held[0]}" if held else "the robot's hand is empty",
        )
        dropped = [
            ObjectVerdict(object=n, ok=False, reason=f"{n} is {_where(now[n])}; it must rest on a place position")
            for n in resting
            if n in now and now[n].state == "loose"
        ]
        return [hand, *dropped]
    raise AssertionError(f"no check for condition {cond.kind!r}")


def _check(
    cond: Condition,
    now: dict[str, ObjectPlacement],
    baseline: dict[str, ObjectPlacement] | None,
    report: dict[str, Any] | None = None,
) -> list[ObjectVerdict]:
    out: list[ObjectVerdict] = []
    if isinstance(cond, AtLocation):
        for name in cond.objects:
            p = now.get(name)
            if p is None:
                out.append(_missing(name))
                continue
            ok = p.state == "on_position" and p.location == cond.location
            out.append(ObjectVerdict(object=name, ok=ok, reason=f"{name} is {_where(p)}"))
    elif isinstance(cond, AtPosition):
        p = now.get(cond.object)
        if p is None:
            return [_missing(cond.object)]
        ok = p.state == "on_position" and (p.location, p.position) == (cond.location, cond.position)
        out.append(ObjectVerdict(object=cond.object, ok=ok, reason=f"{cond.object} is {_where(p)}"))
    elif isinstance(cond, Swapped):
        a, b = cond.objects
        if baseline is None:
            return [
                ObjectVerdict(object=n, ok=False, reason="no record of where it was when the task started")
                for n in (a, b)
            ]
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
    else:
        out = _check_more(cond, now, baseline, report)
    return out


def evaluate(
    task: TaskSpec,
    placements: dict[str, ObjectPlacement],
    baseline: dict[str, ObjectPlacement] | None = None,
    report: dict[str, Any] | None = None,
) -> TaskVerdict:
    """The verdict of `task` for the world whose object placements are given, against the placements
    at the task's start (`baseline`) and the episode's end_task report (its arguments; None when the
    task was never ended)."""
    verdicts = [v for cond in task.success for v in _check(cond, placements, baseline, report)]
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
