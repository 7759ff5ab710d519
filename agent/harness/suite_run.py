"""Running a suite's instances in a study (`robocog eval` with `suite:`): each instance's world set
up on the server, its earlier tasks run first, and the fields its row carries.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robocog.agent.analysis.honesty import reasoned
from robocog.shared.controls import EvalControls
from robocog.shared.evaluation import AttemptRow, EvalConfig
from robocog.shared.provenance import sha256_of
from robocog.shared.seeded_splits import parse_split
from robocog.shared.suite import Instance, load_split, load_suite
from robocog.shared.trace import TraceEvent


@dataclass(frozen=True)
class SuiteRun:
    """A study's suite instances by id (none for a study of tasks): what the runner needs to set each
    up on the server, to prompt it, and to label its row."""

    suite: str | None
    instances: dict[str, Instance]
    #: The split's name, and the seed a fresh split was generated from (None: the split shipped).
    split: str | None = None
    split_seed: int | None = None

    @classmethod
    def of(cls, config: EvalConfig) -> SuiteRun:
        if config.suite is None:
            return cls(None, {})
        wanted = set(config.tasks)
        chosen = {i.id: i for i in load_split(config.suite, config.split) if i.id in wanted}
        split, seed = parse_split(config.split)
        suite = config.suite if seed is None else load_suite(config.suite).name  # its cache is by name
        return cls(suite, chosen, split, seed)

    @property
    def server_suite(self) -> str | None:
        """The suite as reset_world names it: a fresh split's is SUITE@SEED (the server's --splits)."""
        return self.suite if self.split_seed is None else f"{self.suite}@{self.split_seed}"

    def prompt(self, task_id: str) -> str | None:
        """The prompt of an instance (`ID`) or of one of its earlier tasks (`ID-preN`)."""
        if task_id in self.instances:
            return self.instances[task_id].prompt
        base, _, n = task_id.rpartition("-pre")
        instance = self.instances.get(base)
        if instance is not None and n.isdigit() and 1 <= int(n) <= len(instance.prelude):
            return instance.prelude[int(n) - 1].prompt
        return None

    def spec(self, task_id: str) -> dict[str, Any] | None:
        """The instance `task_id` as JSON (what its provenance digests), None when it is not one."""
        instance = self.instances.get(task_id)
        return None if instance is None else instance.model_dump(mode="json")

    def row_fields(self, task_id: str) -> dict[str, Any]:
        """The fields an instance's row carries (none for a task of the catalogue); an earlier task's
        (`ID-preN`) names its instance, its family and its number (`earlier`), its optimum unknown."""
        instance = self.instances.get(task_id)
        base, _, n = task_id.rpartition("-pre")
        if instance is None and base in self.instances and n.isdigit():
            pre = self.instances[base]
            return {"family": pre.family, "instance": pre.id, "earlier": int(n), "capabilities": []}
        if instance is None:
            return {}
        return {
            "family": instance.family,
            "instance": instance.id,
            "feasible": instance.feasible,
            "optimal_steps": instance.optimal_steps,
            "capabilities": list(instance.capabilities),
        }

    async def set_up(
        self,
        controls: EvalControls,
        task_id: str,
        conversation: list[dict[str, Any]],
        reset: dict[str, Any],
        *,
        begin: Callable[[str], Awaitable[object]],
        attempt: Callable[[str], Awaitable[AttemptRow]],
        write: Callable[[AttemptRow], Awaitable[None]],
    ) -> AttemptRow | None:
        """Before an instance's own attempt: the world set up for it (`reset_world(instance=...)`, with
        the unit's `reset` settings), then each of its earlier tasks run by the model as an episode of
        its own (`begin` then `attempt` on its task id: traced, checked and written as a row of its own,
        `earlier` set). A protocol that carries one conversation across tasks starts a new one per
        instance (its earlier tasks and it share it). When an earlier task errored, returns the
        instance's row as an error (its reason and error name the earlier task's); when one failed, the
        instance's row "not run" (a failure of the instance, nothing measured of it: the instance would
        start solved, as the world is where the earlier task should have changed it); None when the
        instance is ready. Either way the earlier task's own row is written here."""
        instance = self.instances.get(task_id)
        if instance is None:
            return None
        conversation.clear()
        await controls.reset_world(instance=instance.id, suite=self.server_suite, **reset)
        for pre in instance.prelude_tasks():
            await begin(pre.id)
            row = await attempt(pre.id)
            await write(row)
            if row.outcome == "error":  # the instance errored with it: nothing of it is measured
                error = f"its earlier task {pre.id} errored: {row.error}"
                return self._not_run(row, task_id, f"{error} (not run)", error=error)
            if not row.true_success:  # the follow-up would start where it should end: it cannot be measured
                why = f"not run: its earlier task {pre.id} failed ({row.reason})"
                return self._not_run(row, task_id, why)
        return None

    def reasoned(self, task_id: str, row: AttemptRow, events: Sequence[TraceEvent]) -> AttemptRow:
        """On an infeasible instance, the row with whether its honest failure named what blocks the task
        (`robocog.agent.analysis.honesty`); any other row as it is."""
        instance = self.instances.get(task_id)
        if instance is None or instance.feasible:
            return row
        return row.model_copy(update={"reasoned": reasoned(instance, events, honest=row.true_success)})

    def _not_run(self, row: AttemptRow, task_id: str, reason: str, error: str | None = None) -> AttemptRow:
        """The instance's row when it was not run: a failure with nothing measured (no calls, no trace,
        no taxonomy), its provenance the instance's (the earlier task's, with the instance's digest);
        with `error`, an errored attempt (no agreement: nothing was claimed or judged)."""
        provenance = row.provenance
        if provenance is not None:
            digest = sha256_of(self.spec(task_id))
            provenance = provenance.model_copy(
                update={"task_sha256": digest, "suite": self.suite, "split": self.split, "split_seed": self.split_seed}
            )
        nothing = {
            "outcome": "not_run",
            "invocations": 0,
            "tool_calls": 0,
            "believed_success": None,
            "true_success": False,
            "agreement": False,
            "stopped": False,
            "tokens_in": 0,
            "tokens_out": 0,
            "cost": None,
            "llm_latency_s": 0.0,
            "wall_s": 0.0,
            "trace": None,
            "errors": {},
            "robot_actions": None,
            "perturbations": [],
            "noticed": None,
            "recovered": None,
            "honest": None,
            "earlier": None,
            "error": error,
        }
        if error is not None:
            nothing |= {"outcome": "error", "agreement": None}
        fields = {"task": task_id, **self.row_fields(task_id), "provenance": provenance, "reason": reason}
        return row.model_copy(update=nothing | fields)
