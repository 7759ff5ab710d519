"""end_task(status, description, summary): end the episode; the report goes to episodic memory.

One episode stores one record. The same end_task (same arguments) called again right after it, as a
client retrying a call whose answer it lost does, stores nothing: it answers with the record already
stored, status success, so the client sees the episode ended. (Any other call after end_task, even an
end_task with another report, begins a new episode, as before.) The record's id derives from the
episode id, so a harness that reruns an attempt under the same episode id (begin_task), even on a new
server after a crash, replaces the record instead of adding a second.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import ACTION, Tool, at_most
from robocog.shared.limits import DESCRIPTION_CHARS, SUMMARY_CHARS
from robocog.shared.results import EndTaskResult, Status

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

logger = logging.getLogger("robocog.server.session")

StatusArg = Annotated[Status, Field(description="'success' only if the task is really done, else 'failure'")]
DescriptionArg = Annotated[
    str,
    Field(description="The task as you were given it", min_length=1, max_length=DESCRIPTION_CHARS),
    at_most(DESCRIPTION_CHARS, "give the task's instruction as you were told it, not a transcript"),
]
SummaryArg = Annotated[
    str,
    Field(
        description="What you did, what went wrong, and what to do differently next time",
        max_length=SUMMARY_CHARS,
    ),
    at_most(SUMMARY_CHARS, "keep to what a later attempt needs: what worked, what failed, what to do differently"),
]


def end_task(robot: RobotSession, status: StatusArg, description: DescriptionArg, summary: SummaryArg) -> EndTaskResult:
    """End the current task with a report. The report is stored in episodic memory, searchable
    by the task description, so later tasks can learn from it. A task has one report: repeating
    the same end_task stores nothing more."""
    episode = robot.episode
    if episode.ended and episode.record_id is not None:
        return EndTaskResult(
            status="success",
            message="This episode already ended; its report was stored once, by the first end_task. Nothing new "
            "was stored.",
            record_id=episode.record_id,
            episode=episode.number,
            episode_id=episode.id,
            tool_calls=episode.tool_calls,
        )
    if not description.strip():
        return EndTaskResult(
            status="failure",
            message="The description is empty: give the task as you were told it.",
            episode=episode.number,
            episode_id=episode.id,
            tool_calls=episode.tool_calls,
        )
    record = robot.memory.add(
        description.strip(),
        status,
        summary.strip(),
        model=robot.caller.model,
        tool_calls=episode.tool_calls,
        duration_s=episode.duration_s,
        episode=episode.id,
    )
    episode.ended = True
    episode.record_id = record.id
    episode.report = {"status": status, "description": description, "summary": summary}
    logger.info("episode %d ended: believed %s after %d tool calls", episode.number, status, episode.tool_calls)
    return EndTaskResult(
        status="success",
        message=f"Task ended with status '{status}'. The report was stored in episodic memory.",
        record_id=record.id,
        episode=episode.number,
        episode_id=episode.id,
        tool_calls=episode.tool_calls,
    )


TOOL = Tool("end_task", "End the task", ACTION, end_task, ends_episode=True)
