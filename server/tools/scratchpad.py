"""add_to_scratchpad(text) and view_scratchpad: the working memory of the current task."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.memory.scratchpad import MAX_CHARS, MAX_ENTRIES, MAX_ENTRY_CHARS
from robocog.server.tools.base import ACTION, READ_ONLY, Tool, at_most
from robocog.shared.results import ScratchpadResult, ScratchpadView

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

TextArg = Annotated[
    str,
    Field(
        description=f"A thought, plan or observation to keep, at most {MAX_ENTRY_CHARS} characters",
        min_length=1,
        max_length=MAX_ENTRY_CHARS,
    ),
    at_most(MAX_ENTRY_CHARS, "shorten the note or split it into several"),
]

#: The description of add_to_scratchpad, with the scratchpad's default bounds (the session's).
ADD_DESCRIPTION = (
    "Write down thoughts and plans on the scratchpad, the working memory of the current task. "
    f"One entry may have at most {MAX_ENTRY_CHARS} characters (a longer one is refused: split it). "
    f"The scratchpad keeps at most {MAX_ENTRIES} entries and {MAX_CHARS} characters in all; when a new "
    "entry does not fit, the oldest entries are dropped to make room."
)


def add_to_scratchpad(robot: RobotSession, text: TextArg) -> ScratchpadResult:
    """Write a note on the scratchpad (the tool's description is `ADD_DESCRIPTION`)."""
    pad = robot.scratchpad
    try:
        added = pad.add(text)
    except ValueError as exc:
        return ScratchpadResult(status="failure", message=str(exc), entries=len(pad))
    note = f" The {added.dropped} oldest entries were dropped to make room." if added.dropped else ""
    return ScratchpadResult(
        status="success",
        message=f"Written to the scratchpad ({added.entries} entries).{note}",
        entries=added.entries,
        dropped=added.dropped,
    )


def view_scratchpad(robot: RobotSession) -> ScratchpadView:
    """Read everything written on the scratchpad during the current task, oldest first."""
    n = len(robot.scratchpad)
    return ScratchpadView(
        message=f"The scratchpad has {n} entries." if n else "The scratchpad is empty.",
        content=robot.scratchpad.view(),
        entries=n,
    )


ADD = Tool("add_to_scratchpad", "Write to the scratchpad", ACTION, add_to_scratchpad, doc=ADD_DESCRIPTION)
VIEW = Tool("view_scratchpad", "Read the scratchpad", READ_ONLY, view_scratchpad)
