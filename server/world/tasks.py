"""Ground-truth verdicts: a task's success conditions evaluated against object placements.

Placements come from `World.placements()` (physics state). A `swapped` condition compares with
the placements recorded when the task started (`baseline`).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

from robocog.assets import ASSETS_DIR
from robocog.shared.results import ObjectPlacement, ObjectVerdict, TaskVerdict
from robocog.shared.tasks import AtLocation, AtPosition, Condition, Swapped, TaskSpec, load_tasks

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


def _check(
    cond: Condition, now: dict[str, ObjectPlacement], baseline: dict[str, ObjectPlacement] | None
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
    return out


def evaluate(
    task: TaskSpec,
    placements: dict[str, ObjectPlacement],
    baseline: dict[str, ObjectPlacement] | None = None,
) -> TaskVerdict:
    """The verdict of `task` for the world whose object placements are given."""
    verdicts = [v for cond in task.success for v in _check(cond, placements, baseline)]
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
