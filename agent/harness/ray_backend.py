"""`robocog eval --ray [ADDRESS]`: the units of a study run on a Ray cluster, the results stay on the driver.

The driver plans the study exactly as a local run does (`run_eval`, `plan_units`, `--resume`) and
keeps one queue of units (a model x a trial: the iterations of a trial share memory, so a unit
never splits). Each of its `workers` is a Ray actor that owns a robot: it spawns its own
`robocog-server --profile eval` over stdio on its node, with a node-local data directory (or the
Chroma server of `--memory-url` in `server_args`), and runs the units it is given through the same
`Runner.run_unit` and `Runner.attempt` as a local worker. An actor streams what happens back to the
driver as it happens (a Ray streaming generator): each attempt's row with its trace, each skipped
task, and the unit's end; the driver writes the rows to the same results file, under the same lock,
with the same progress, and writes the traces beside it where a local run puts them.

Nothing in the robot or the model changes with Ray: the same study gives the same rows.

Ray is optional (`pip install 'robocog[ray]'`); this module imports it only when a study runs.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import shutil
import tempfile
from collections.abc import AsyncIterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.agent.client.connection import connect, leaf_message
from robocog.agent.client.model import warm_up_litellm
from robocog.agent.client.trace_sinks import images_dir
from robocog.agent.harness.progress import Progress
from robocog.agent.harness.runner import Runner
from robocog.shared.errors import ConfigError, ServerConnectionError
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec

if TYPE_CHECKING:
    from robocog.agent.client.connection import Robot

#: The one line `robocog eval --ray` prints without the extra.
NEEDS_RAY = "--ray needs Ray: pip install 'robocog[ray]'"

Unit = tuple[ModelSpec, int, int]  # a model, a trial, the memory iteration to start from
#: What an actor streams back: ("row", row JSON, trace text or None, {picture file name: bytes}),
#: ("skip", n), ("done", resume iteration or None), or ("error", message) when its server could not
#: be reached.
Event = tuple[Any, ...]


def forwarded_environment(config: EvalConfig) -> dict[str, str]:
    """The driver's variables an actor on another node needs: robocog's own (`ROBOCOG_*`), the keys
    of the study's models (`api_key_env`, and the providers' usual `*_API_KEY`, `*_API_BASE`), and
    the offline switches (telemetry off, LiteLLM's local cost map)."""
    wanted = {m.api_key_env for m in config.models if m.api_key_env}
    env = {
        k: v
        for k, v in os.environ.items()
        if k in wanted or k.startswith("ROBOCOG_") or k.endswith(("_API_KEY", "_API_BASE"))
    }
    env.setdefault("ANONYMIZED_TELEMETRY", "False")
    env.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", os.environ.get("LITELLM_LOCAL_MODEL_COST_MAP", "True"))
    return env


# --- the actor side ------------------------------------------------------------------------------


class _ForwardedProgress(Progress):
    """A unit's progress on an actor: each skipped task goes to the driver, which counts it."""

    def __init__(self) -> None:
        super().__init__(total=0)
        self.events: asyncio.Queue[Event] | None = None

    def advance(self, n: int = 1, row: AttemptRow | None = None) -> None:
        if self.events is not None and row is None and n:
            self.events.put_nowait(("skip", n))


class RemoteRunner(Runner):
    """A `Runner` on an actor: its files live in a node-local directory, and each row goes to the
    driver with its trace instead of into a results file."""

    def __init__(self, config: EvalConfig, out: Path, server_command: list[str] | None) -> None:
        self.forward = _ForwardedProgress()
        super().__init__(config, out, server_command, progress=self.forward)

    async def write(self, row: AttemptRow) -> None:
        trace, images = None, {}
        if row.trace is not None:
            path = self.out.parent / row.trace
            if path.exists():
                trace = path.read_text(encoding="utf-8")
                path.unlink()
            folder = images_dir(path)  # the pictures the trace refers to (look's), sent along
            if folder.is_dir():
                images = {f.name: f.read_bytes() for f in sorted(folder.iterdir()) if f.is_file()}
                shutil.rmtree(folder, ignore_errors=True)
        assert self.forward.events is not None
        self.forward.events.put_nowait(("row", row.model_dump_json(), trace, images))


class UnitActor:
    """A robot on a Ray node: one server process, kept across the units it runs (a new one after
    its server broke, on the same memory), as a local worker keeps one. Ray makes it an actor."""

    def __init__(
        self, config_json: str, out_name: str, server_command: list[str] | None, index: int, env: dict[str, str]
    ):
        os.environ.update(env)
        config = EvalConfig.model_validate_json(config_json)
        self.dir = Path(tempfile.mkdtemp(prefix=f"robocog-ray-{index}-"))
        self.runner = RemoteRunner(config, self.dir / out_name, server_command)
        self.index = index
        self.jobs: asyncio.Queue[tuple[Unit, asyncio.Queue[Event]]] = asyncio.Queue()
        self.serving: asyncio.Task[None] | None = None

    async def run(self, spec_json: str, trial: int, start: int) -> AsyncIterator[Event]:
        """Run a unit; yields its events, the last one ("done", ...) or ("error", ...)."""
        if self.serving is None:
            self.serving = asyncio.create_task(self._serve())
        events: asyncio.Queue[Event] = asyncio.Queue()
        await self.jobs.put(((ModelSpec.model_validate_json(spec_json), trial, start), events))
        while True:
            event = await events.get()
            yield event
            if event[0] in ("done", "error"):
                return

    async def _serve(self) -> None:
        """The actor's robot: connect when a unit arrives, run units on it until its server breaks."""
        runner = self.runner
        warm = asyncio.create_task(asyncio.to_thread(warm_up_litellm, [m.model for m in runner.config.models]))
        while True:
            job: tuple[Unit, asyncio.Queue[Event]] | None = await self.jobs.get()
            try:
                async with connect(runner.spec(self.index)) as robot:
                    await warm
                    while job is not None:
                        resume_at = await self._run(robot, job)
                        if resume_at is not None:
                            job = None
                            break  # reconnect on the next unit: a new server, the same memory on disk
                        job = await self.jobs.get()
            except Exception as exc:
                if job is not None:
                    job[1].put_nowait(("error", leaf_message(exc)))

    async def _run(self, robot: Robot, job: tuple[Unit, asyncio.Queue[Event]]) -> int | None:
        (spec, trial, start), events = job
        self.runner.forward.events = events
        try:
            resume_at = await self.runner.run_unit(robot, spec, trial, start)
        finally:
            self.runner.forward.events = None
        events.put_nowait(("done", resume_at))
        return resume_at

    async def close(self) -> None:
        """Stop the robot's server and remove the node-local files."""
        if self.serving is not None:
            self.serving.cancel()
            with contextlib.suppress(BaseException):
                await self.serving
        shutil.rmtree(self.dir, ignore_errors=True)


# --- the driver side -----------------------------------------------------------------------------


def _import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise ConfigError(NEEDS_RAY) from None
    return ray


async def run_on_ray(runner: Runner, queue: asyncio.Queue[Unit], workers: int, address: str | None) -> None:
    """Run the units of `queue` on `workers` Ray actors of the cluster at `address` (None: Ray's
    default: $RAY_ADDRESS, else the cluster `ray start` began on this machine, else a new local one),
    writing every row through `runner` as a local run does."""
    ray = _import_ray()
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # nothing phones home
    if address:
        await asyncio.to_thread(check_reachable, address)
    try:
        ray.init(address=address, log_to_driver=False, logging_level=logging.WARNING)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        where = f"at {address}" if address else "(Ray's default address)"
        raise ServerConnectionError(f"--ray: cannot reach a Ray cluster {where}: {leaf_message(exc)}") from exc
    actor_class = ray.remote(num_cpus=1)(UnitActor)
    try:
        async with asyncio.TaskGroup() as tg:
            for index in range(workers):
                tg.create_task(_drive(ray, actor_class, runner, queue, index))
    finally:
        ray.shutdown()


def check_reachable(address: str) -> None:
    """Fail at once, in one line, when nothing listens at a `HOST:PORT` address (Ray itself would
    retry for minutes); other forms (`auto`, `ray://...`) are left to Ray."""
    import socket

    host, sep, port = address.rpartition(":")
    if not sep or "://" in address or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=10).close()
    except OSError as exc:
        raise ServerConnectionError(
            f"--ray: no Ray cluster answers at {address} ({exc.strerror or exc}); start one with "
            f"`ray start --head --port {port}`, or give the address `ray start` printed"
        ) from None


async def _drive(ray: Any, actor_class: Any, runner: Runner, queue: asyncio.Queue[Unit], index: int) -> None:
    """One actor's share of the study: take units from the driver's queue until it is empty."""
    if queue.empty():
        return
    config = runner.config
    env = forwarded_environment(config)
    actor = actor_class.remote(config.model_dump_json(), runner.out.name, runner.server_command, index, env)
    try:
        while not queue.empty():
            spec, trial, start = queue.get_nowait()
            resume_at: int | None = start
            # A unit whose server broke goes on at its next iteration on the same actor (a new
            # server on the same node-local memory): another actor's robot has other memories.
            while resume_at is not None and resume_at < config.memory_iterations:
                resume_at = await _run_remote(ray, actor, runner, spec, trial, resume_at, index)
    finally:
        with contextlib.suppress(Exception):
            await actor.close.remote()
        ray.kill(actor)  # frees its CPU for an actor still waiting for one


async def store_row(runner: Runner, row: AttemptRow, trace: str | None, images: dict[str, bytes]) -> None:
    """Write a row an actor sent, with its trace and the trace's pictures, where a local run puts them."""
    if row.trace is not None and trace is not None:
        path = runner.out.parent / row.trace
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(trace, encoding="utf-8")
        if images:
            folder = images_dir(path)
            folder.mkdir(exist_ok=True)
            for name, data in images.items():
                (folder / Path(name).name).write_bytes(data)  # a bare file name, never a path
    await runner.write(row)


async def _run_remote(
    ray: Any, actor: Any, runner: Runner, spec: ModelSpec, trial: int, start: int, index: int
) -> int | None:
    """Run one unit on `actor`, writing its rows as they come; returns where to resume it (its server broke)."""
    try:
        async for ref in actor.run.remote(spec.model_dump_json(), trial, start):
            event = await ref
            kind = event[0]
            if kind == "row":
                await store_row(runner, AttemptRow.model_validate_json(event[1]), event[2], event[3])
            elif kind == "skip":
                runner.progress.advance(int(event[1]))
            elif kind == "done":
                return None if event[1] is None else int(event[1])
            else:
                raise ServerConnectionError(f"ray worker {index}: {event[1]}")
    except ray.exceptions.RayError as exc:
        raise ServerConnectionError(f"ray worker {index}: {leaf_message(exc)}") from exc
    raise ServerConnectionError(f"ray worker {index}: the unit ended without a result")
