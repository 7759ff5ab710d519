"""search_memory(query, k=None): past task reports, by semantic similarity to the query.

An answer is bounded: each text is cut to its limit by the memory (a record written before the limits
may be huge), and the results that would take the answer's texts past `SEARCH_ANSWER_CHARS` are left
out, the farthest first, and counted in the message.
"""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from robocog.server.tools.base import READ_ONLY, Tool, at_most
from robocog.shared.limits import QUERY_CHARS, SEARCH_ANSWER_CHARS
from robocog.shared.memory import MemoryRecord
from robocog.shared.results import Experience, MemorySearchResult

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession

QueryArg = Annotated[
    str,
    Field(description="A description of the current task, e.g. its instruction", max_length=QUERY_CHARS),
    at_most(QUERY_CHARS, "describe the task in a sentence or two, e.g. its instruction"),
]
KArg = Annotated[
    int | None,
    Field(
        description="How many experiences to return; default: the server's setting (3 unless a harness set another)",
        ge=1,
        le=20,
    ),
]


def search_memory(robot: RobotSession, query: QueryArg, k: KArg = None) -> MemorySearchResult:
    """Search past experiences (task reports written by end_task) by semantic similarity to the
    query. Each result gives the task, how it ended and the summary of what was done."""
    if not query.strip():
        return MemorySearchResult(
            status="failure", message="The query is empty: describe the task you want experiences of."
        )
    hits = robot.memory.search(query, k if k is not None else robot.search_k)
    found = [_experience(h.record, h.distance, verified=robot.memory_labels == "verified") for h in hits]
    results, chars = [], 0
    for experience in found:
        chars += len(experience.task_description) + len(experience.summary)
        if chars > SEARCH_ANSWER_CHARS:
            break
        results.append(experience)
    message = (
        f"The query returned {len(results)} results of previous experiences."
        if results
        else "No previous experiences are stored yet."
    )
    if len(results) < len(found):
        message += (
            f" {len(found) - len(results)} farther results were left out to keep the answer under "
            f"{SEARCH_ANSWER_CHARS} characters of text."
        )
    return MemorySearchResult(status="success", message=message, results=results)


def _experience(record: MemoryRecord, distance: float, *, verified: bool) -> Experience:
    """A record as the agent sees it: with `verified`, the ground-truth outcome where it is known."""
    checked = record.verified_status if verified else None
    return Experience(
        task_description=record.task_description,
        status=checked or record.believed_status,
        status_source="verified" if checked else "believed",
        summary=record.summary,
        when=record.created_at,
        distance=round(distance, 4),
    )


DESCRIPTION = (
    f"{inspect.cleandoc(search_memory.__doc__ or '')}\n\nAn answer holds at most {SEARCH_ANSWER_CHARS} "
    "characters of task descriptions and summaries: the farthest results past that are left out (the message "
    "says how many)."
)
TOOL = Tool("search_memory", "Search episodic memory", READ_ONLY, search_memory, doc=DESCRIPTION)
