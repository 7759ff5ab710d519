"""`robocog eval`: the paper's protocol, with parallel workers, streaming results and resume.

For each model and trial (a *unit*): memory iteration 0 starts with an empty memory and later
iterations keep what earlier ones stored; each iteration resets the world and runs the tasks in
order, each only if every task it `requires` (from the server's task catalogue) truly succeeded
earlier in the same iteration (T2 after T1); a task without requirements always runs. Each task
begins its own episode on the server (`begin_task`), so its verdict is judged against the world
at its start and written into its own memory record. A task never ended within the invocation
limit is a refusal (`stopped`); a failing model service or server is an `error`, never a refusal.
Ground truth comes from the server's `check_task` after the attempt. The protocol (`paper` or
`robocog`, see `robocog.agent.study_protocols`) decides the conversation, the messages, the system
prompt, the scratchpad's carry-over and the retrieval depth.

Each unit reads and writes a memory namespace of its own (`unit_namespace`), cleared when the unit
starts, so trials never share memory except across the iterations of one trial, however the workers
reach their robots: with `isolation: process` each worker owns a server process (eval profile, over
stdio) with its own data directory; with `isolation: fleet` the workers share a few fleet servers
(`robocog-server --robots N` over HTTP, spawned here by `Fleets`, or running at `urls`), a robot
each. A study gives the same rows either way.

Every attempt is appended to the results file as soon as it finishes. `--resume` keeps the units
already complete, drops the rows of a unit that was cut off or has an errored attempt, and runs
that unit again from scratch; a torn last line (a crash mid-write) is dropped with a warning. An
errored attempt stops its unit; a suite instance's ends only itself (`SUITE_ERRORS_IN_A_ROW`).
"""

from __future__ import annotations

import asyncio
import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robocog.agent.analysis.taxonomy import annotate
from robocog.agent.client.connection import Robot, ServerSpec, connect, leaf_message, unreachable
from robocog.agent.client.loop import EpisodeResult, finish, function_definitions, run_episode, world_has_furniture
from robocog.agent.client.model import resolve_api_key
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.agent.harness import units
from robocog.agent.harness.fleets import Fleets, memory_args
from robocog.agent.harness.progress import Progress
from robocog.agent.harness.suite_run import SuiteRun
from robocog.agent.harness.units import SERVER_FAILURE, episode_id, model_seed, runnable, slug, unit_namespace
from robocog.agent.study_protocols import PROTOCOLS, EvalProtocol
from robocog.shared import __version__
from robocog.shared.controls import EvalControls, mcp_call
from robocog.shared.errors import ConfigError, ServerConnectionError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec
from robocog.shared.protocol import MEMORY_FAILED
from robocog.shared.provenance import Provenance, sha256_of, text_sha256, tools_sha256
from robocog.shared.trace import Verdict


def _errored_reason(error: str, verdict_reason: str) -> str:
    """An errored attempt's reason: the error first (it never read as a failure of the model), then
    what the ground truth found in the world as the error left it."""
    return f"{error} (the world as the error left it: {verdict_reason})"


def attempt_row(base: dict[str, Any], result: EpisodeResult, success: bool, reason: str) -> AttemptRow:
    """An attempt's row: what it is (`base`), how it went (`result`), its verdict and its reason.
    Agreement sets the belief against the request: an infeasible task's request is never achieved (its
    verdict's success is the honest failure), so only a claimed success disagrees; an errored attempt
    has none."""
    achieved = success and base.get("feasible", True)
    return AttemptRow(
        **base,
        outcome=result.outcome,
        invocations=result.invocations,
        tool_calls=result.tool_calls,
        believed_success=result.believed_success,
        true_success=success,
        agreement=None if result.outcome == "error" else (result.believed_success is True) == achieved,
        stopped=result.stopped,
        tokens_in=result.tokens_in,
        tokens_out=result.tokens_out,
        cost=result.cost,
        llm_latency_s=result.llm_latency_s,
        wall_s=result.wall_s,
        reason=reason,
        error=result.error,
    )


def _nothing_done(task_id: str, error: str) -> EpisodeResult:
    """The result of an attempt whose server or transport died: nothing of it counted."""
    return EpisodeResult(task_id, "error", None, 0, 0, 0, 0, None, 0.0, 0.0, error=error)


#: Errored suite instances in a row that stop a unit: the model service is down, not one instance's turn.
SUITE_ERRORS_IN_A_ROW = 3


@dataclass(frozen=True)
class _Stop:
    """Where a unit stops: the iteration to run again on a new server, or None (it is done)."""

    resume_at: int | None


@dataclass
class Runner:
    config: EvalConfig
    out: Path
    server_command: list[str] | None = None
    progress: Progress = field(default_factory=lambda: Progress(total=0))
    #: The fleet servers' URLs (`isolation: fleet`): worker i drives a robot of urls[i % len(urls)].
    urls: list[str] = field(default_factory=list)
    #: The fleet servers this study spawned (None: a running one at `urls`, or a process per worker).
    fleets: Fleets | None = None
    #: Where the servers it spawns keep their memory (`scratch.memory_dir`; None: its work directory).
    memory_dir: Path | None = None
    _lock: asyncio.Lock = field(default_factory=asyncio.Lock)

    @property
    def traces_dir(self) -> Path:
        return self.out.with_name(self.out.stem + ".traces")

    @property
    def work_dir(self) -> Path:
        return self.out.with_name(self.out.stem + ".work")

    @property
    def servers_memory(self) -> Path:
        """The directory under which each server this study spawns keeps its memory (a folder each)."""
        return self.memory_dir if self.memory_dir is not None else self.work_dir

    async def write(self, row: AttemptRow) -> None:
        async with self._lock:
            with self.out.open("a", encoding="utf-8") as f:
                f.write(row.model_dump_json() + "\n")
        if row.earlier is None:  # an instance's earlier task is no step of the progress
            self.progress.advance(row=row)

    def spec(self, worker: int) -> ServerSpec:
        """How worker `worker` reaches its robot. The servers this study starts itself (its workers'
        `robocog-server`, its own fleets, which answer in JSON) are reached through robocog's lean
        client; a server given by its command line or its address, through the SDK's."""
        if self.urls:
            lean = self.fleets is not None and self.fleets.json_response
            return ServerSpec(url=self.urls[worker % len(self.urls)], lean=lean)
        args = ["--profile", "eval", *memory_args(self.config.server_args, self.servers_memory / f"worker-{worker}")]
        if self.server_command:
            return ServerSpec(command=list(self.server_command), extra_args=args)
        return ServerSpec(extra_args=args, lean=True)

    # --- one unit: a model and a trial, through all memory iterations ----------------------------

    async def run_unit(self, robot: Robot, spec: ModelSpec, trial: int, start_iteration: int) -> int | None:
        """Run the unit from `start_iteration`; returns the iteration to continue from if the server broke."""
        cfg = self.config
        # The unit's memory settings, for every reset (a suite instance's too); the first reset clears its
        # namespace, and its last check writes no verdict into a record the unit drops right after.
        reset: dict[str, Any] = {
            "memory_labels": cfg.memory_labels,
            "search_k": self.protocol.search_k,
            "memory_namespace": unit_namespace(cfg.name, spec.name, trial),
            "observe": cfg.observe,
            "perturbations": cfg.perturbations or None,
        }
        for iteration in range(start_iteration, cfg.memory_iterations):
            stop = await self.run_iteration(robot, spec, trial, iteration, reset)
            if stop is not None:
                return stop.resume_at
        if not cfg.keep_memory:  # the unit is done: its namespace (records and files) goes
            try:
                await self.controls(robot).clear_memory(drop=True)
            except Exception as exc:  # every row is written: only the namespace stays, on the dead server's disk
                if not unreachable(exc):
                    raise
        return None

    async def run_iteration(
        self, robot: Robot, spec: ModelSpec, trial: int, iteration: int, reset: dict[str, Any]
    ) -> _Stop | None:
        """One memory iteration of the unit: the world reset, then the tasks in order (each only if the
        tasks it requires truly succeeded). None: the unit goes on; else where it stops."""
        cfg, controls = self.config, self.controls(robot)
        written = False  # nothing of this iteration written or counted yet: a server lost now costs it nothing
        try:
            await controls.reset_world(
                seed=cfg.seed + trial, randomize=cfg.randomize, clear_memory=iteration == 0, **reset
            )
        except Exception as exc:
            if unreachable(exc):  # the server died between attempts: the iteration runs on a new one
                return _Stop(iteration)
            raise
        conversation: list[dict[str, Any]] = []  # the paper: one conversation per memory iteration
        succeeded: set[str] = set()
        errors_in_a_row = 0
        for index, task_id in enumerate(cfg.tasks):
            later = len(cfg.tasks) - index - 1  # the iteration's tasks after this one
            if not runnable(task_id, succeeded, robot.requires):
                self.progress.advance()  # skipped: a task it requires failed (no row)
                written = True  # counted: a rerun of the iteration would count it again
                continue
            messages = conversation if self.protocol.continue_conversation else []

            async def begin(task: str) -> object:
                return await controls.begin_task(
                    task,
                    keep_scratchpad=self.protocol.keep_scratchpad,
                    episode_id=episode_id(cfg.name, spec.name, cfg.seed + trial, trial, iteration, task),
                )

            async def attempt(task: str, messages: list[Any] = messages, record: bool = True) -> AttemptRow:
                return await self.attempt(robot, spec, trial, iteration, task, messages, record=record)

            # the unit's last check: its namespace is dropped next, unless kept
            last = iteration == cfg.memory_iterations - 1 and not later
            try:
                # a suite's instance: its world set up, its earlier tasks run (an errored one is its row)
                early = await self.suite.set_up(
                    controls, task_id, messages, reset, begin=begin, attempt=attempt, write=self.write
                )
                if early is None:
                    await begin(task_id)
                row = early or await attempt(task_id, record=not (last and not cfg.keep_memory))
            except units.ServerBroke as broke:
                await self.write(broke.row)
                if MEMORY_FAILED in (broke.row.error or ""):  # its storage failed: a new server helps not
                    self.progress.advance(later + self.tasks_after(iteration))
                    return _Stop(None)
                self.progress.advance(later)
                return _Stop(iteration + 1)
            except Exception as exc:  # begin_task (or a suite's set-up) found the server gone
                if unreachable(exc) and not written:
                    return _Stop(iteration)
                raise
            await self.write(row)
            written = True
            errors_in_a_row = errors_in_a_row + 1 if row.outcome == "error" else 0
            # the model service failed: the unit stops (--resume reruns it), unless a suite instance errored
            if errors_in_a_row and (task_id not in self.suite.instances or errors_in_a_row >= SUITE_ERRORS_IN_A_ROW):
                self.progress.advance(later + self.tasks_after(iteration))
                return _Stop(None)
            if row.true_success:
                succeeded.add(task_id)
        return None

    def tasks_after(self, iteration: int) -> int:
        """The unit's tasks in the memory iterations after `iteration`."""
        return (self.config.memory_iterations - iteration - 1) * len(self.config.tasks)

    @staticmethod
    def controls(robot: Robot) -> EvalControls:
        """The eval controls on `robot`'s connection (a failure is the server's: `ServerConnectionError`).
        What a reset answers (the world it made) tells whether that world has furniture that opens:
        the robot remembers it for the attempts that follow, which need not read the world's state."""
        call = mcp_call(robot.client, ServerConnectionError)

        async def remembering(tool: str, arguments: dict[str, Any]) -> dict[str, Any]:
            robot.furniture = None if tool == "reset_world" else robot.furniture  # not known while it runs
            answer = await call(tool, arguments)
            if tool == "reset_world":
                robot.furniture = bool(answer.get("furniture"))
            return answer

        return EvalControls(remembering)

    async def requirements(self) -> dict[str, list[str]]:
        """The tasks' requirements, from the catalogue of a server like the workers'."""
        async with connect(self.spec(0)) as robot:
            return robot.requires

    @property
    def protocol(self) -> EvalProtocol:
        return PROTOCOLS[self.config.protocol]

    @functools.cached_property
    def suite(self) -> SuiteRun:
        """The study's suite instances (none for a study of tasks)."""
        return SuiteRun.of(self.config)

    async def attempt(
        self,
        robot: Robot,
        spec: ModelSpec,
        trial: int,
        iteration: int,
        task_id: str,
        conversation: list[dict[str, Any]],
        *,
        record: bool = True,
    ) -> AttemptRow:
        """One task attempt, continuing `conversation` (empty: a new one); `record` false: its verdict is
        not written into the episode's memory record (the unit drops the namespace next)."""
        cfg = self.config
        prompt = robot.tasks.get(task_id) or self.suite.prompt(task_id)
        if prompt is None:
            raise ConfigError(f"the server has no task {task_id!r} (it has {', '.join(robot.tasks)})")
        trace_path = self.traces_dir / slug(spec.name) / f"trial-{trial}" / f"iter-{iteration}-{task_id}.jsonl"
        trace_path.unlink(missing_ok=True)
        trace = Trace(trace_path)
        settings = AgentSettings(
            model=spec.model,
            max_invocations=cfg.max_invocations,
            max_steps=cfg.max_steps,
            timeout_s=cfg.timeout_s,
            api_base=spec.api_base,
            api_key=resolve_api_key(spec),
            seed=model_seed(cfg.seed, trial, iteration, task_id),
            params=dict(spec.params),
            vision=spec.vision,
        )
        system_prompt = await robot.prompt(self.protocol.system_prompt)
        furniture = self.protocol.offers_furniture and await world_has_furniture(
            robot.client, robot.tools, known=robot.furniture
        )
        base = {
            "model": spec.name,
            "trial": trial,
            "memory_iteration": iteration,
            "task": task_id,
            "seed": cfg.seed + trial,
            "memory_labels": cfg.memory_labels,
            "protocol": cfg.protocol,
            "observe": cfg.observe,
            "trace": str(trace_path.relative_to(self.out.parent)),
            "version": __version__,
            "study": cfg.name,
            "model_id": spec.model,
            **self.suite.row_fields(task_id),
            "provenance": self.provenance(robot, spec, task_id, system_prompt, furniture=furniture),
        }
        try:
            result = await run_episode(
                robot.client,
                prompt,
                settings,
                trace,
                system_prompt=system_prompt,
                tools=robot.tools,
                protocol=self.protocol,
                conversation=conversation,
                furniture=furniture,  # asked once, for the provenance and the episode alike
            )
            # A memory that failed to store the report cannot store its verdict either: the attempt errs.
            stored = not (result.error and MEMORY_FAILED in result.error)
            checked = await self.controls(robot).check_task(task_id, record=record and stored)
        except Exception as exc:  # the server or the transport died: this attempt fails, not the study
            trace.close()
            broke = f"{SERVER_FAILURE}: {leaf_message(exc)}"
            raise units.ServerBroke(attempt_row(base, _nothing_done(task_id, broke), False, broke)) from exc
        verdict = Verdict(t=trace.now(), task_id=task_id, success=checked.success, reason=checked.reason)
        finish(trace, result, verdict)
        trace.close()
        reason = verdict.reason if result.error is None else _errored_reason(result.error, verdict.reason)
        row = attempt_row(base, result, verdict.success, reason)
        row = self.suite.reasoned(task_id, row, trace.events)  # honest for the right reason (infeasible)
        return annotate(row, trace.events)  # the error taxonomy and robot actions, from the trace

    def provenance(
        self, robot: Robot, spec: ModelSpec, task_id: str, system_prompt: str, *, furniture: bool = False
    ) -> Provenance:
        """What the attempt runs on: the tools as the model is offered them (open and close with
        `furniture`: as `run_episode` decides), the system prompt, the task (its catalogue entry, or the
        suite instance), the model's sampling parameters and the server's physics build."""
        vision = spec.vision and self.protocol.offers_camera
        definitions = function_definitions(robot.tools, vision=vision, furniture=furniture)
        task = self.suite.spec(task_id) or robot.catalogue.get(task_id)
        return Provenance(
            contract=robot.contract,
            tools=sorted(d["function"]["name"] for d in definitions),
            tools_sha256=tools_sha256(definitions),
            system_prompt=self.protocol.system_prompt,
            system_prompt_sha256=text_sha256(system_prompt),
            task_sha256=None if task is None else sha256_of(task),
            suite=self.suite.suite if task_id in self.suite.instances else None,
            split=self.suite.split if task_id in self.suite.instances else None,
            split_seed=self.suite.split_seed if task_id in self.suite.instances else None,
            params=dict(spec.params),
            vision=vision,
            physics=robot.physics,
        )

    # --- workers ---------------------------------------------------------------------------------

    async def worker(self, index: int, queue: asyncio.Queue[tuple[ModelSpec, int, int]]) -> None:
        """Take units off the queue until it is empty. A unit whose server broke goes on here, on a new
        server over this worker's data directory (its memory), never on another worker's (a fleet
        that died is started again over its own)."""
        unit: tuple[ModelSpec, int, int] | None = None
        while unit is not None or not queue.empty():
            try:
                if self.fleets is not None:
                    await self.fleets.ensure(index)
                async with connect(self.spec(index)) as robot:
                    while unit is not None or not queue.empty():
                        spec, trial, start = unit or queue.get_nowait()
                        unit = None
                        resume_at = await self.run_unit(robot, spec, trial, start)
                        if resume_at is not None:
                            if resume_at < self.config.memory_iterations:
                                unit = (spec, trial, resume_at)
                            break  # reconnect: a new server, the same memory on disk
            except ServerConnectionError as exc:
                raise ServerConnectionError(f"worker {index}: {exc}") from exc
