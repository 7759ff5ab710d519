"""One robot's session: its world, its memories and the current episode, behind plain methods.

Every capability the MCP server publishes is a method here, returning a pydantic result, so the
tools' behaviour lives in one place and is tested without MCP. An episode is one task: it begins
at reset (or with the first call after end_task) and ends with end_task, which writes the report
to episodic memory. Not thread-safe: the app serialises calls (one PyBullet client, one driver).
"""

from __future__ import annotations

import time
from typing import Any

from robocog.server.config import MemoryLabels, SessionConfig
from robocog.server.memory.embedding import embed
from robocog.server.memory.episodic import EpisodicMemory
from robocog.server.memory.scratchpad import Scratchpad
from robocog.server.world.tasks import evaluate, task_catalogue
from robocog.server.world.world import ProgressFn, World
from robocog.shared.memory import MemoryRecord
from robocog.shared.results import (
    EndTaskResult,
    Experience,
    GrabResult,
    LookAroundResult,
    MemorySearchResult,
    MoveResult,
    ObjectPlacement,
    PlaceResult,
    ScratchpadResult,
    ScratchpadView,
    Status,
    TaskVerdict,
    WorldState,
)
from robocog.shared.tasks import TaskSpec


class RobotSession:
    """The robot, its episodic memory and scratchpad, and the bookkeeping of the current episode."""

    def __init__(self, config: SessionConfig, *, world: World | None = None, memory: EpisodicMemory | None = None):
        self.config = config
        self.memory_labels: MemoryLabels = config.memory_labels
        self.world = world or World(config.scene, seed=config.seed, randomize=config.randomize, gui=config.gui)
        self.memory = memory or EpisodicMemory(config.data_dir, url=config.memory_url, namespace=config.namespace)
        self.scratchpad = Scratchpad()
        self.tasks: dict[str, TaskSpec] = task_catalogue()
        self.episode = 0
        self._start_episode()
        # Load the embedding model now (checksum, ONNX session, tokenizer): the first search_memory
        # of an episode then costs milliseconds, not a third of a second.
        embed(["warm up"])

    def close(self) -> None:
        self.world.close()
        self.memory.close()

    # --- episodes ------------------------------------------------------------------------------

    def _start_episode(self) -> None:
        self.episode += 1
        self.tool_calls = 0
        self.ended = False
        self.started = time.monotonic()
        self.baseline: dict[str, ObjectPlacement] = self.world.placements()
        self.last_record_id: str | None = None
        self.scratchpad.clear()

    def _count_call(self) -> None:
        if self.ended:
            self._start_episode()
        self.tool_calls += 1

    # --- the robot's tools ---------------------------------------------------------------------

    def look_around(self) -> LookAroundResult:
        self._count_call()
        return self.world.look_around()

    def move_to(self, location: str, progress: ProgressFn | None = None) -> MoveResult:
        self._count_call()
        return self.world.move_to(location, progress=progress)

    def grab(self, object: str) -> GrabResult:
        self._count_call()
        return self.world.grab(object)

    def place(self, location: str, position: str) -> PlaceResult:
        self._count_call()
        return self.world.place(location, position)

    def add_to_scratchpad(self, text: str) -> ScratchpadResult:
        self._count_call()
        try:
            added = self.scratchpad.add(text)
        except ValueError as exc:
            return ScratchpadResult(status="failure", message=str(exc), entries=len(self.scratchpad))
        note = f" The {added.dropped} oldest entries were dropped to make room." if added.dropped else ""
        return ScratchpadResult(
            status="success",
            message=f"Written to the scratchpad ({added.entries} entries).{note}",
            entries=added.entries,
            dropped=added.dropped,
        )

    def view_scratchpad(self) -> ScratchpadView:
        self._count_call()
        n = len(self.scratchpad)
        return ScratchpadView(
            message=f"The scratchpad has {n} entries." if n else "The scratchpad is empty.",
            content=self.scratchpad.view(),
            entries=n,
        )

    def search_memory(self, query: str, k: int | None = None) -> MemorySearchResult:
        self._count_call()
        if not query.strip():
            return MemorySearchResult(
                status="failure", message="The query is empty: describe the task you want experiences of."
            )
        hits = self.memory.search(query, k or self.config.search_k)
        results = [self._experience(h.record, h.distance) for h in hits]
        message = (
            f"The query returned {len(results)} results of previous experiences."
            if results
            else "No previous experiences are stored yet."
        )
        return MemorySearchResult(status="success", message=message, results=results)

    def _experience(self, record: MemoryRecord, distance: float) -> Experience:
        verified = self.memory_labels == "verified" and record.verified_status is not None
        return Experience(
            task_description=record.task_description,
            status=record.verified_status if verified and record.verified_status else record.believed_status,
            status_source="verified" if verified else "believed",
            summary=record.summary,
            when=record.created_at,
            distance=round(distance, 4),
        )

    def end_task(self, status: Status, description: str, summary: str, model: str | None = None) -> EndTaskResult:
        """End the episode with the agent's report, and store it in episodic memory."""
        self._count_call()
        if not description.strip():
            return EndTaskResult(
                status="failure",
                message="The description is empty: give the task as you were told it.",
                episode=self.episode,
                tool_calls=self.tool_calls,
            )
        record = self.memory.add(
            description.strip(),
            status,
            summary.strip(),
            model=model,
            tool_calls=self.tool_calls,
            duration_s=round(time.monotonic() - self.started, 3),
            episode=str(self.episode),
        )
        self.ended = True
        self.last_record_id = record.id
        return EndTaskResult(
            status="success",
            message=f"Task ended with status '{status}'. The report was stored in episodic memory.",
            record_id=record.id,
            episode=self.episode,
            tool_calls=self.tool_calls,
        )

    # --- evaluation controls -------------------------------------------------------------------

    def reset_world(
        self, seed: int | None = None, randomize: bool = False, memory_labels: MemoryLabels | None = None
    ) -> WorldState:
        """Back to the start state (episodic memory is kept: that is the point of it)."""
        state = self.world.reset(seed=seed, randomize=randomize)
        if memory_labels is not None:
            self.memory_labels = memory_labels
        self._start_episode()
        return state

    def task(self, task_id: str) -> TaskSpec:
        try:
            return self.tasks[task_id]
        except KeyError:
            raise ValueError(f"unknown task {task_id!r}; known tasks: {', '.join(self.tasks)}") from None

    def check_task(self, task_id: str) -> TaskVerdict:
        """The ground-truth verdict of `task_id` against the world now and the episode's start.

        When the episode has ended with a report, the verdict is also written into that memory
        record as its verified status.
        """
        verdict = evaluate(self.task(task_id), self.world.placements(), self.baseline)
        if self.ended and self.last_record_id is not None:
            self.memory.set_verified(self.last_record_id, "success" if verdict.success else "failure")
        return verdict

    def clear_memory(self) -> int:
        """Forget every episode in this namespace; returns how many were removed."""
        removed = self.memory.count()
        self.memory.clear()
        return removed

    # --- resources -----------------------------------------------------------------------------

    def state(self) -> WorldState:
        return self.world.state()

    def semantic_map(self) -> dict[str, Any]:
        m = self.world.map
        return {
            "locations": [{"name": n, "x": x, "y": y, "neighbours": m.neighbours[n]} for n, (x, y) in m.points.items()],
            "edges": [list(e) for e in self.world.scene.edges],
            "place_positions": [
                {"location": loc, "position": name, "support": pos.spec.support}
                for (loc, name), pos in self.world.positions.items()
            ],
        }
