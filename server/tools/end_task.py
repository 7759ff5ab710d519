"""end_task(status, description, summary): end the episode; the report goes to episodic memory."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import ACTION, Tool
from robocog.shared.results import EndTaskResult, Status

if TYPE_CHECKING:
    from robocog.server.session import RobotSession

logger = logging.getLogger("robocog.server.session")

StatusArg = Annotated[Status, Field(description="'success' only if the task is really done, else 'failure'")]
DescriptionArg = Annotated[str, Field(description="The task as you were given it", min_length=1)]
SummaryArg = Annotated[str, Field(description="What you did, what went wrong, and what to do differently next time")]


def end_task(robot: RobotSession, status: StatusArg, description: DescriptionArg, summary: SummaryArg) -> EndTaskResult:
    """End the current task with a report. The report is stored in episodic memory, searchable
    by the task description, so later tasks can learn from it."""
    episode = robot.episode
    if not description.strip():
        return EndTaskResult(
            status="failure",
            message="The description is empty: give the task as you were told it.",
            episode=episode.number,
            tool_calls=episode.tool_calls,
        )
    record = robot.memory.add(
        description.strip(),
        status,
        summary.strip(),
        model=robot.caller.model,
        tool_calls=episode.tool_calls,
        duration_s=episode.duration_s,
        episode=str(episode.number),
    )
    episode.ended = True
    episode.record_id = record.id
    logger.info("episode %d ended: believed %s after %d tool calls", episode.number, status, episode.tool_calls)
    return EndTaskResult(
        status="success",
        message=f"Task ended with status '{status}'. The report was stored in episodic memory.",
        record_id=record.id,
        episode=episode.number,
        tool_calls=episode.tool_calls,
    )


TOOL = Tool("end_task", "End the task", ACTION, end_task)
