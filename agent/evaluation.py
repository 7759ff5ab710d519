"""`robocog eval`: the paper's protocol, with parallel workers, streaming results and resume.

For each model and trial (a *unit*): memory iteration 0 starts with an empty memory and later
iterations keep what earlier ones stored; each iteration resets the world and runs the tasks in
order, each only if every task it `requires` (from the server's task catalogue) truly succeeded
earlier in the same iteration (T2 after T1); a task without requirements always runs. Each task
begins its own episode on the server (`begin_task`), so its verdict is judged against the world
at its start and written into its own memory record. A task never ended within the invocation
limit is a refusal (`stopped`); a failing model service or server is an `error`, never a refusal.
Ground truth comes from the server's `check_task` after the attempt. The protocol (`paper` or
`robocog`, see `robocog.agent.protocols`) decides the conversation, the messages, the system
prompt, the scratchpad's carry-over and the retrieval depth.

Each unit reads and writes a memory namespace of its own (`unit_namespace`), cleared when the unit
starts, so trials never share memory except across the iterations of one trial, however the workers
reach their robots: with `isolation: process` each worker owns a server process (eval profile, over
stdio) with its own data directory; with `isolation: fleet` the workers share a few fleet servers
(`robocog-server --robots N` over HTTP, spawned here by `Fleets`, or running at `urls`), a robot
each. A study gives the same rows either way.

Every attempt is appended to the results file as soon as it finishes. `--resume` keeps the units
already complete, drops the rows of a unit that was cut off or has an errored attempt, and runs
that unit again from scratch; a torn last line (a crash mid-write) is dropped with a warning.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import hashlib
import re
import shutil
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robocog.agent.connection import Robot, ServerSpec, connect, leaf_message
from robocog.agent.fleets import Fleets, memory_args
from robocog.agent.loop import AgentSettings, finish, run_episode
from robocog.agent.model import check_credentials, resolve_api_key, warm_up_litellm
from robocog.agent.protocols import PROTOCOLS, EvalProtocol
from robocog.agent.suite import SuiteRun
from robocog.agent.taxonomy import annotate
from robocog.agent.trace import Trace
from robocog.shared import __version__
from robocog.shared.errors import ConfigError, ServerConnectionError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec
from robocog.shared.trace import Verdict


def slug(text: str) -> str:
    """`text` as a file name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "model"


def episode_id(study: str, model: str, seed: int, trial: int, iteration: int, task: str) -> str:
    """The server-side episode id of an attempt (begin_task): the same for a rerun of the attempt
    (`--resume` after a crash), so the server replaces its memory record instead of adding a second."""
    return (
        "eval-" + hashlib.sha256(f"{study}\x00{model}\x00{seed}:{trial}:{iteration}:{task}".encode()).hexdigest()[:32]
    )


def unit_namespace(study: str, model: str, trial: int) -> str:
    """The memory namespace of a unit (a model and a trial): its own, whichever robot runs it."""
    return "unit-" + hashlib.sha256(f"{study}\x00{model}\x00{trial}".encode()).hexdigest()[:24]


def model_seed(seed: int, trial: int, iteration: int, task: str) -> int:
    """A seed for the model per attempt (independent draws for stochastic models)."""
    digest = hashlib.sha256(f"{seed}:{trial}:{iteration}:{task}".encode()).digest()
    return int.from_bytes(digest[:4], "big")


#: The error of an attempt during which the server or the transport died.
SERVER_FAILURE = "server failure"

Requirements = Mapping[str, Sequence[str]]  # task id -> tasks that must have succeeded first


def read_rows(path: Path) -> list[AttemptRow]:
    """The attempts of a results file, in order (none when it does not exist)."""
    if not path.exists():
        return []
    lines = [line for line in path.read_text(encoding="utf-8", errors="replace").splitlines() if line.strip()]
    rows = []
    for number, line in enumerate(lines, 1):
        try:
            rows.append(AttemptRow.model_validate_json(line))
        except ValueError as exc:
            if number == len(lines):  # a crash while the last row was written: that attempt reruns
                print(f"robocog: {path}: dropping a torn last line ({number})", file=sys.stderr)
                break
            raise ConfigError(f"{path}: line {number} is not a result row: {exc.__class__.__name__}") from exc
    return rows


def mend_torn_tail(path: Path) -> None:
    """Before a resumed run appends to `path`: cut a torn last line (the row `read_rows` dropped,
    whose attempt reruns), and end a whole last row that lost its newline, so every appended row
    starts a line of its own."""
    if not path.exists():
        return
    data = path.read_bytes()
    body = data.rstrip()
    start = body.rfind(b"\n") + 1
    try:
        AttemptRow.model_validate_json(body[start:])
    except ValueError:
        with path.open("r+b") as f:
            f.truncate(start)
        return
    if not data.endswith(b"\n"):
        with path.open("ab") as f:
            f.write(b"\n")


def runnable(task_id: str, succeeded: set[str], requires: Requirements) -> bool:
    """Whether every task `task_id` requires has truly succeeded (earlier in the same iteration)."""
    return all(r in succeeded for r in requires.get(task_id, ()))


def errored(rows: list[AttemptRow]) -> list[AttemptRow]:
    """The attempts that a failing model service or server cut short (outcome "error")."""
    return [r for r in rows if r.outcome == "error"]


def unit_complete(rows: list[AttemptRow], config: EvalConfig, requires: Requirements) -> bool:
    """A unit is complete when no attempt of it errored and its last memory iteration has closed:
    every task ran, or was skipped because a task it requires failed."""
    if errored(rows):
        return False
    last = iter([r for r in rows if r.memory_iteration == config.memory_iterations - 1])  # in run order
    succeeded: set[str] = set()
    for task_id in config.tasks:
        if not runnable(task_id, succeeded, requires):
            continue
        row = next(last, None)
        if row is None or row.task != task_id:  # not run yet (or not by these rules: run it again)
            return False
        if row.true_success:
            succeeded.add(task_id)
    return True


@dataclass
class Progress:
    """Counts for the progress display."""

    total: int
    done: int = 0
    successes: int = 0
    attempts: int = 0
    errors: int = 0
    on_change: Callable[[Progress], None] | None = None
    on_error: Callable[[AttemptRow], None] | None = None

    def advance(self, n: int = 1, row: AttemptRow | None = None) -> None:
        self.done += n
        if row is not None and row.outcome == "error":
            self.errors += 1
            if self.on_error is not None:
                self.on_error(row)
        elif row is not None:
            self.attempts += 1
            self.successes += int(row.true_success)
        if self.on_change is not None:
            self.on_change(self)


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
    _lock: asyncio.Lock = field(default_factory=asyncio.Lock)

    @property
    def traces_dir(self) -> Path:
        return self.out.with_name(self.out.stem + ".traces")

    @property
    def work_dir(self) -> Path:
        return self.out.with_name(self.out.stem + ".work")

    async def write(self, row: AttemptRow) -> None:
        async with self._lock:
            with self.out.open("a", encoding="utf-8") as f:
                f.write(row.model_dump_json() + "\n")
        self.progress.advance(row=row)

    def spec(self, worker: int) -> ServerSpec:
        if self.urls:
            return ServerSpec(url=self.urls[worker % len(self.urls)])
        args = ["--profile", "eval", *memory_args(self.config.server_args, self.work_dir / f"worker-{worker}")]
        if self.server_command:
            return ServerSpec(command=list(self.server_command), extra_args=args)
        return ServerSpec(extra_args=args)

    # --- one unit: a model and a trial, through all memory iterations ----------------------------

    async def run_unit(self, robot: Robot, spec: ModelSpec, trial: int, start_iteration: int) -> int | None:
        """Run the unit from `start_iteration`; returns the iteration to continue from if the server broke."""
        cfg, protocol = self.config, self.protocol
        seed = cfg.seed + trial
        # The unit's memory settings, for every reset (a suite instance's too).
        reset = {
            "memory_labels": cfg.memory_labels,
            "search_k": protocol.search_k,
            "memory_namespace": unit_namespace(cfg.name, spec.name, trial),
        }
        for iteration in range(start_iteration, cfg.memory_iterations):
            await _control(robot, "reset_world", seed=seed, randomize=cfg.randomize, **reset)
            if iteration == 0:
                await _control(robot, "clear_memory")
            conversation: list[dict[str, Any]] = []  # the paper: one conversation per memory iteration
            succeeded: set[str] = set()
            for index, task_id in enumerate(cfg.tasks):
                if not runnable(task_id, succeeded, robot.requires):
                    self.progress.advance()  # skipped: a task it requires failed (no row)
                    continue
                messages = conversation if protocol.continue_conversation else []
                try:
                    # a suite's instance: its world set up, its earlier tasks run (an errored one is its row)
                    early = await self.suite.set_up(self, robot, spec, trial, iteration, task_id, messages, reset)
                    if early is None:
                        await _control(
                            robot,
                            "begin_task",
                            task_id=task_id,
                            keep_scratchpad=protocol.keep_scratchpad,
                            episode_id=episode_id(cfg.name, spec.name, seed, trial, iteration, task_id),
                        )
                    row = early or await self.attempt(robot, spec, trial, iteration, task_id, messages)
                except ServerBroke as broke:
                    await self.write(broke.row)
                    self.progress.advance(len(cfg.tasks) - index - 1)
                    return iteration + 1
                await self.write(row)
                if row.outcome == "error":  # the model service failed: the unit stops; --resume reruns it
                    later = (cfg.memory_iterations - iteration - 1) * len(cfg.tasks)
                    self.progress.advance(len(cfg.tasks) - index - 1 + later)
                    return None
                if row.true_success:
                    succeeded.add(task_id)
        return None

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
    ) -> AttemptRow:
        """One task attempt, continuing `conversation` (empty: a new one)."""
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
        base = {
            "model": spec.name,
            "trial": trial,
            "memory_iteration": iteration,
            "task": task_id,
            "seed": cfg.seed + trial,
            "memory_labels": cfg.memory_labels,
            "protocol": cfg.protocol,
            "trace": str(trace_path.relative_to(self.out.parent)),
            "version": __version__,
            "study": cfg.name,
            "model_id": spec.model,
            **self.suite.row_fields(task_id),
        }
        try:
            result = await run_episode(
                robot.client,
                prompt,
                settings,
                trace,
                system_prompt=await robot.prompt(self.protocol.system_prompt),
                tools=robot.tools,
                protocol=self.protocol,
                conversation=conversation,
            )
            checked = await _control(robot, "check_task", task_id=task_id)
        except Exception as exc:  # the server or the transport died: this attempt fails, not the study
            trace.close()
            raise ServerBroke(
                AttemptRow(
                    **base,
                    outcome="error",
                    invocations=0,
                    tool_calls=0,
                    believed_success=None,
                    true_success=False,
                    agreement=False,
                    stopped=False,
                    tokens_in=0,
                    tokens_out=0,
                    cost=None,
                    llm_latency_s=0.0,
                    wall_s=0.0,
                    error=f"{SERVER_FAILURE}: {leaf_message(exc)}",
                )
            ) from exc
        verdict = Verdict(t=trace.now(), task_id=task_id, success=bool(checked["success"]), reason=checked["reason"])
        finish(trace, result, verdict)
        trace.close()
        believed = result.believed_success
        # Agreement sets the belief against the request: an infeasible task's request is never
        # achieved (its verdict's success is the honest failure), so only a claimed success disagrees.
        achieved = verdict.success and base.get("feasible", True)
        row = AttemptRow(
            **base,
            outcome=result.outcome,
            invocations=result.invocations,
            tool_calls=result.tool_calls,
            believed_success=believed,
            true_success=verdict.success,
            agreement=(believed is True) == achieved,
            stopped=result.stopped,
            tokens_in=result.tokens_in,
            tokens_out=result.tokens_out,
            cost=result.cost,
            llm_latency_s=result.llm_latency_s,
            wall_s=result.wall_s,
            reason=verdict.reason,
            error=result.error,
        )
        return annotate(row, trace.events)  # the error taxonomy and robot actions, from the trace

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


class ServerBroke(ServerConnectionError):
    """The server died during an attempt; carries the attempt's row."""

    def __init__(self, row: AttemptRow) -> None:
        super().__init__(row.error)
        self.row = row


async def _control(robot: Robot, tool: str, **arguments: Any) -> dict[str, Any]:
    result = await robot.client.call_tool(tool, arguments)
    if result.is_error or not isinstance(result.structured_content, dict):
        text = " ".join(getattr(b, "text", "") for b in result.content)
        raise ServerConnectionError(f"{tool} failed: {text}")
    return result.structured_content


def plan_units(
    config: EvalConfig, out: Path, rows: list[AttemptRow], requires: Requirements
) -> list[tuple[ModelSpec, int, int]]:
    """The units still to run, given the `rows` already in `out`; drops the rows of units that were
    cut off (rewriting `out`)."""
    by_unit: dict[tuple[str, int], list[AttemptRow]] = {}
    for row in rows:
        by_unit.setdefault(row.unit, []).append(row)
    complete = {unit for unit, unit_rows in by_unit.items() if unit_complete(unit_rows, config, requires)}
    kept = [r for r in rows if r.unit in complete]
    if len(kept) != len(rows):
        tmp = out.with_suffix(out.suffix + ".tmp")
        tmp.write_text("".join(r.model_dump_json() + "\n" for r in kept), encoding="utf-8")
        tmp.replace(out)
    return [
        (spec, trial, 0)
        for trial in range(config.trials)
        for spec in config.models
        if (spec.name, trial) not in complete
    ]


async def run_eval(
    config: EvalConfig,
    out: Path,
    *,
    workers: int | None = None,
    resume: bool = False,
    server_command: list[str] | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    on_error: Callable[[AttemptRow], None] | None = None,
    ray_address: str | None = None,
    urls: Sequence[str] = (),
) -> list[AttemptRow]:
    """Run the study; returns every row of the results file. With `ray_address` (a cluster's
    address, or "" for Ray's default), the units run as Ray actors (`robocog.agent.distributed`);
    with `urls`, worker i drives a robot of the fleet server running at urls[i mod len(urls)]; else the
    workers reach their robots as `config.isolation` says (a spawned server each, or spawned fleets)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = read_rows(out)
    if rows and not resume:
        raise ConfigError(f"{out} already holds {len(rows)} results: use --resume to continue, or another --out")
    mend_torn_tail(out)
    for spec in config.models:  # a missing key fails the study before any server starts
        check_credentials(spec.model, spec.api_base, resolve_api_key(spec))
    runner = Runner(config, out, server_command, urls=list(urls))
    requested = workers or config.workers
    fleets = None
    if not urls and ray_address is None and config.isolation == "fleet":
        fleets = Fleets(
            requested,
            runner.work_dir,
            processes=config.fleet_processes,
            server_command=server_command,
            server_args=config.server_args,
        )
    async with contextlib.AsyncExitStack() as stack:
        if fleets is not None:
            # LiteLLM's import and first call (seconds) happen while the fleets start.
            warming = asyncio.create_task(asyncio.to_thread(warm_up_litellm, [m.model for m in config.models]))
            runner.fleets = await stack.enter_async_context(fleets)
            runner.urls = fleets.urls
            await warming
        # Which units are complete depends on the tasks' requirements: only the server knows them.
        pending = plan_units(config, out, rows, await runner.requirements() if rows else {})
        per_unit = config.memory_iterations * len(config.tasks)
        runner.progress = Progress(total=len(pending) * per_unit, on_change=on_progress, on_error=on_error)
        queue: asyncio.Queue[tuple[ModelSpec, int, int]] = asyncio.Queue()
        for unit in pending:
            queue.put_nowait(unit)
        n = max(1, min(requested, len(pending) or 1))
        if pending and ray_address is not None:
            from robocog.agent.distributed import run_on_ray

            await run_on_ray(runner, queue, n, ray_address or None)
        elif pending:
            if fleets is None:  # LiteLLM's import and first call (seconds) happen while the servers start.
                await asyncio.to_thread(warm_up_litellm, [m.model for m in config.models])
            async with asyncio.TaskGroup() as tg:
                for i in range(n):
                    tg.create_task(runner.worker(i, queue))
    shutil.rmtree(runner.work_dir, ignore_errors=True)
    return read_rows(out)


def summary_line(rows: list[AttemptRow]) -> str:
    """True successes per model and task (per family for a suite's instances), on one line."""
    by: dict[tuple[str, str], list[AttemptRow]] = {}
    for r in rows:
        by.setdefault((r.model, r.family or r.task), []).append(r)
    parts = []
    for (model, task), group in sorted(by.items()):
        counted = [r for r in group if r.outcome != "error"]
        wins = sum(r.true_success for r in counted)
        failed = len(group) - len(counted)
        parts.append(
            f"{model} {task}: {wins}/{len(counted)} true successes" + (f" ({failed} errored)" if failed else "")
        )
    return "; ".join(parts)
