"""`robocog eval`'s entry: run a study (on server processes, fleets, running fleets or Ray) and
sum up its rows in one line.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path

from robocog.agent.analysis.results_file import mend_torn_tail, read_rows
from robocog.agent.client.model import check_credentials, resolve_api_key, warm_up_litellm
from robocog.agent.harness.fleets import Fleets
from robocog.agent.harness.progress import Progress
from robocog.agent.harness.runner import Runner
from robocog.agent.harness.scratch import memory_dir
from robocog.agent.harness.units import plan_units
from robocog.shared.errors import ConfigError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec, instance_rows, success
from robocog.shared.evaluation import counted as is_counted


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
    address, or "" for Ray's default), the units run as Ray actors (`robocog.agent.harness.ray_backend`);
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
    spawned = not urls and ray_address is None  # the servers are started here (not a running fleet's, not Ray's)
    async with contextlib.AsyncExitStack() as stack:
        if spawned:  # their memory, in RAM where there is room (`scratch`); it goes last, once they have stopped
            runner.memory_dir = stack.enter_context(memory_dir(runner.work_dir, keep_memory=config.keep_memory))
        fleets = None
        if spawned and config.isolation == "fleet":
            fleets = Fleets(
                requested,
                runner.work_dir,
                processes=config.fleet_processes,
                server_command=server_command,
                server_args=config.server_args,
                memory_dir=runner.memory_dir,
            )
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
            from robocog.agent.harness.ray_backend import run_on_ray

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
    """Successes (`robocog.shared.evaluation.success`: on an infeasible family, honest failures) per
    model and task (per family for a suite's instances), on one line, as the report counts them."""
    by: dict[tuple[str, str], list[AttemptRow]] = {}
    for r in instance_rows(rows):  # an instance's earlier task is no attempt at the instance
        by.setdefault((r.model, r.family or r.task), []).append(r)
    parts = []
    for (model, task), group in sorted(by.items()):
        counted = [r for r in group if is_counted(r)]
        wins = sum(success(r) for r in counted)
        failed = len(group) - len(counted)
        parts.append(f"{model} {task}: {wins}/{len(counted)} successes" + (f" ({failed} errored)" if failed else ""))
    return "; ".join(parts)
