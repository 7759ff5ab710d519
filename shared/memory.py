"""Schemas of episodic memory: one stored episode and one search hit."""

from datetime import datetime

from pydantic import BaseModel, ConfigDict, Field, field_validator

from robocog.shared.results import Status


class MemoryRecord(BaseModel):
    """One past episode as episodic memory keeps it."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(
        description="Unique id of the record (uuid hex): derived from `episode` when there is one (an "
        "episode has one record), else random."
    )
    task_description: str = Field(description="The task as it was given to the robot; the embedded, searchable text.")
    believed_status: Status = Field(description="Whether the agent believed it succeeded at the task.")
    summary: str = Field(description="The agent's own summary of what it did and learned.")
    verified_status: Status | None = Field(
        default=None,
        description="The outcome according to ground truth, when it is known; None otherwise.",
    )
    model: str | None = Field(default=None, description="The model that ran the episode, if known.")
    tool_calls: int | None = Field(default=None, ge=0, description="How many tool calls the episode made, if known.")
    duration_s: float | None = Field(
        default=None, ge=0, description="Wall-clock duration of the episode in seconds, if known."
    )
    created_at: str = Field(description="When the record was written, ISO-8601 in UTC.")
    episode: str | None = Field(default=None, description="Id of the episode that wrote the record, if any.")

    @field_validator("created_at")
    @classmethod
    def _check_created_at(cls, value: str) -> str:
        """created_at must be ISO-8601 with a timezone, so records order by time."""
        if datetime.fromisoformat(value).tzinfo is None:
            raise ValueError(f"created_at must include a timezone (UTC), got {value!r}")
        return value


class MemoryHit(BaseModel):
    """A record returned by a memory search, with its distance to the query."""

    model_config = ConfigDict(extra="forbid")

    record: MemoryRecord = Field(description="The matching record.")
    distance: float = Field(description="Cosine distance to the query: 0 is identical, smaller is closer.")
