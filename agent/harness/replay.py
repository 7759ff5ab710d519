"""Verified by replay (`robocog submit verify`): every attempt's tool calls, read from its trace, run
again in a fresh world on a real server, and its verdict recomputed from the physics.

The rows are replayed unit by unit (a model and a trial, in file order), as `robocog eval` ran them:
each memory iteration resets the world with the row's seed and the unit's memory namespace (cleared
at iteration 0), a suite instance's world is set up from its instance (the shipped suite the row's
provenance names, or the fresh split its seed regenerates: its scene, start, perturbations), its
earlier tasks replayed before it, and each
task begins its own episode. Each tool call the attempt's trace records is sent to the server with
its recorded arguments (a call the client rejected without the server, bad JSON or a tool not
offered, keeps its recorded result); the new results and perturbations take the place of the
recorded ones, and the attempt is judged by the server's `check_task` and by the error taxonomy
(`robocog.agent.analysis.taxonomy.annotate`) over the new trace. `COMPARED` lists what must equal the
row: the verdict, whether the request was achieved, the belief end_task stated, the tool calls, the
robot actions, the perturbations and the error taxonomy.

What replay cannot reproduce (none of it moves a verdict in a study of robocog's own settings): what
search_memory answers (the memory holds the replay's own records; the calls and the world are the
same), timing, tokens and cost, and a study's own `randomize`, `perturbations` or server arguments
(rows do not record them: such a study replays as if they were off). Errored attempts (left out of
every score) and instances not run (their earlier task failed: that row is replayed) are not.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from robocog.agent.analysis.taxonomy import annotate
from robocog.agent.client.connection import Robot, ServerSpec, connect
from robocog.agent.client.slips import decode_arguments
from robocog.agent.harness.units import episode_id, unit_namespace
from robocog.agent.study_protocols import PROTOCOLS
from robocog.shared.controls import EvalControls, mcp_call
from robocog.shared.errors import ServerConnectionError
from robocog.shared.evaluation import AttemptRow, achieved
from robocog.shared.perturbations import PERTURBATION_META_KEY, PerturbationEvent
from robocog.shared.trace import Perturbed, RunStarted, ToolCall, ToolResult, TraceEvent, Verdict

#: What a replayed attempt must give as its row says, and how to read it off a row.
COMPARED: tuple[str, ...] = (
    "true_success",
    "achieved",
    "believed_success",
    "tool_calls",
    "robot_actions",
    "perturbations",
    "errors",
)

Status = Literal["matches", "differs", "not replayed"]


def compared(row: AttemptRow) -> dict[str, Any]:
    """The fields of `row` that replay recomputes (`COMPARED`)."""
    return {
        "true_success": row.true_success,
        "achieved": achieved(row),
        "believed_success": row.believed_success,
        "tool_calls": row.tool_calls,
        "robot_actions": row.robot_actions,
        "perturbations": list(row.perturbations),
        "errors": dict(row.errors),
    }


@dataclass(frozen=True)
class Replayed:
    """One row's replay: `status`, what differs (field: (recorded, replayed)), why it was not replayed,
    and the seconds it took."""

    number: int
    row: AttemptRow
    status: Status
    differs: dict[str, tuple[Any, Any]] = field(default_factory=dict)
    why: str = ""
    seconds: float = 0.0

    @property
    def name(self) -> str:
        r = self.row
        return f"row {self.number} ({r.model}, trial {r.trial}, iteration {r.memory_iteration}, {r.task})"


def _text(result: Any) -> str:
    parts = [getattr(block, "text", "") for block in result.content]
    return "\n".join(p for p in parts if p) or json.dumps(result.structured_content)


async def replay_calls(robot: Robot, events: Sequence[TraceEvent]) -> list[TraceEvent]:
    """The trace `events` with every tool call sent again to `robot`'s server: its recorded results and
    perturbations replaced by the new ones (a call the client had rejected keeps its recorded result)."""
    started = next((e for e in events if isinstance(e, RunStarted)), None)
    offered = set(started.tools) if started is not None else None
    recorded: dict[str, list[TraceEvent]] = {}
    for e in events:
        if isinstance(e, ToolResult | Perturbed):
            recorded.setdefault(e.id, []).append(e)
    out: list[TraceEvent] = []
    for e in events:
        if isinstance(e, ToolResult | Perturbed | Verdict):
            continue
        out.append(e)
        if not isinstance(e, ToolCall):
            continue
        arguments, _, wrong = decode_arguments(e.raw_arguments or "{}")
        if wrong is not None or arguments is None or (offered is not None and e.name not in offered):
            out += recorded.get(e.id, [])  # the server never saw it
            continue
        t0 = time.monotonic()
        try:
            result = await robot.client.call_tool(e.name, arguments)
        except Exception as exc:
            raise ServerConnectionError(f"the robot server failed on {e.name} while replaying: {exc}") from exc
        structured = result.structured_content if isinstance(result.structured_content, dict) else None
        out.append(
            ToolResult(
                t=e.t,
                invocation=e.invocation,
                id=e.id,
                name=e.name,
                is_error=bool(result.is_error),
                content=_text(result),
                structured=structured,
                latency_s=round(time.monotonic() - t0, 4),
            )
        )
        for happened in (result.meta or {}).get(PERTURBATION_META_KEY, []):
            event = PerturbationEvent.model_validate(happened)
            out.append(Perturbed(t=e.t, invocation=e.invocation, id=e.id, event=event))
    return out


def _believed(events: Sequence[TraceEvent]) -> bool | None:
    """end_task's status as the replayed calls state it (the last end_task the server accepted)."""
    calls = {e.id: e for e in events if isinstance(e, ToolCall)}
    believed = None
    for e in events:
        if isinstance(e, ToolResult) and e.name == "end_task" and not e.is_error:
            arguments = calls[e.id].arguments if e.id in calls else None
            believed = None if arguments is None else arguments.get("status") == "success"
    return believed


def _suites(rows: Sequence[AttemptRow]) -> dict[str, str]:
    """The suite each instance is set up from, as reset_world names it (a fresh split's is SUITE@SEED,
    the server's --splits holding it), read off the instance's own rows: an earlier task's provenance
    names no suite."""
    out: dict[str, str] = {}
    for r in rows:
        p = r.provenance
        if r.instance and r.earlier is None and p is not None and p.suite:
            out[r.instance] = p.suite if p.split_seed is None else f"{p.suite}@{p.split_seed}"
    return out


def _units(rows: Sequence[AttemptRow]) -> dict[tuple[str, str, int], list[int]]:
    units: dict[tuple[str, str, int], list[int]] = {}
    for i, r in enumerate(rows):
        units.setdefault((r.study, r.model, r.trial), []).append(i)
    return units


class Replayer:
    """Replays rows on one robot (`robot`): `unit` replays one model's trial, in file order."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.controls = EvalControls(mcp_call(robot.client, ServerConnectionError))

    async def unit(
        self, rows: Sequence[AttemptRow], indices: Sequence[int], traces: Sequence[list[TraceEvent] | None]
    ) -> list[Replayed]:
        out: list[Replayed] = []
        iteration: int | None = None
        reset: dict[str, Any] = {}
        set_up: set[str] = set()
        suites = _suites([rows[i] for i in indices])
        for i in indices:
            r = rows[i]
            protocol = PROTOCOLS[r.protocol]
            if r.memory_iteration != iteration:
                iteration = r.memory_iteration
                reset = {
                    "memory_labels": r.memory_labels,
                    "search_k": protocol.search_k,
                    "memory_namespace": unit_namespace(f"replay-{r.study}", r.model, r.trial),
                }
                if r.observe is not None:
                    reset["observe"] = r.observe
                await self.controls.reset_world(seed=r.seed, clear_memory=iteration == 0, **reset)
                set_up = set()
            if r.outcome in ("error", "not_run"):
                why = "an errored attempt" if r.outcome == "error" else "not run (its earlier task failed)"
                out.append(Replayed(i + 1, r, "not replayed", why=why))
                continue
            events = traces[i]
            if events is None:
                out.append(Replayed(i + 1, r, "not replayed", why="no trace"))
                continue
            started = time.perf_counter()
            if r.instance and r.instance not in set_up:
                suite = suites.get(r.instance, r.provenance.suite if r.provenance else None)
                await self.controls.reset_world(instance=r.instance, suite=suite, **reset)
                set_up.add(r.instance)
            episode = episode_id(f"replay-{r.study}", r.model, r.seed, r.trial, iteration, r.task)
            await self.controls.begin_task(r.task, keep_scratchpad=protocol.keep_scratchpad, episode_id=episode)
            replayed = await replay_calls(self.robot, events)
            verdict = await self.controls.check_task(r.task)
            fresh = r.model_copy(
                update={
                    "true_success": verdict.success,
                    "believed_success": _believed(replayed),
                    "tool_calls": sum(isinstance(e, ToolCall) for e in replayed),
                }
            )
            fresh = annotate(fresh, replayed)
            was, now = compared(r), compared(fresh)
            differs = {k: (was[k], now[k]) for k in COMPARED if was[k] != now[k]}
            status: Status = "differs" if differs else "matches"
            out.append(Replayed(i + 1, r, status, differs, seconds=time.perf_counter() - started))
        return out


async def replay(
    rows: Sequence[AttemptRow], traces: Sequence[list[TraceEvent] | None], spec: ServerSpec
) -> list[Replayed]:
    """Every row replayed on one server reached by `spec` (a fresh world per unit), in row order."""
    results: dict[int, Replayed] = {}
    async with connect(spec) as robot:
        replayer = Replayer(robot)
        for indices in _units(rows).values():
            for done in await replayer.unit(rows, indices, traces):
                results[done.number] = done
    return [results[n] for n in sorted(results)]
