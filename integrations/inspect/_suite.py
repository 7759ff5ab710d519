"""The robocog suite as an Inspect task, `robocog/suite`: one sample per instance of a split.

Each sample's solver starts its own `robocog-server --profile eval`, sets the world up for the instance
(`reset_world(instance=..., suite=...)`: its scene, start, perturbations and observation), runs each
of its earlier tasks (the memory family's) as an episode of its own through the same react() agent,
and then the instance's own task; the verdict is `check_task`'s, as in `robocog eval` with `suite:`
(`robocog.agent.harness.suite_run`): an earlier task that fails fails the instance, which is not run.
The score is `robocog/t1`'s; the metrics add success per family and per capability, and the false
success rate per family (an infeasible instance is a success only when honestly reported failed).

A fresh split (`-T split=test@12345`, issue 47) is generated from its seed on first use, as `robocog
eval --split` does; each sample's server is told where its instances are (`--splits`) and names the
suite SUITE@SEED, so its samples carry the seed in their metadata (`split_seed`).
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Sequence
from typing import Literal, cast

from inspect_ai import Epochs, Task, task
from inspect_ai.agent import AgentState
from inspect_ai.dataset import Sample
from inspect_ai.model import ChatMessage, ChatMessageUser
from inspect_ai.scorer import (
    Metric,
    MetricProtocol,
    SampleScore,
    Score,
    Scorer,
    Target,
    Value,
    grouped,
    mean,
    mean_score,
    metric,
    pass_k,
    scorer,
)
from inspect_ai.solver import Generate, Solver, TaskState, solver
from inspect_ai.tool import ToolDef, mcp_connection
from inspect_ai.util import span

from robocog.agent.suitegen import generate_on_demand
from robocog.inspect._tasks import (
    METRICS,
    PROTOCOL,
    ROBOT_TOOL_NAMES,
    SETUP_KEY,
    VERDICT_KEY,
    believed_status,
    controls_of,
    judged_episode,
    robocog_server,
    robot_agent,
    verdict_score,
)
from robocog.shared.family_files import CAPABILITIES
from robocog.shared.protocol import FURNITURE_TOOLS
from robocog.shared.seeded_splits import parse_split
from robocog.shared.suite import DEFAULT_SUITE, Instance, fresh_split, load_split, load_suite, select

#: The suite `robocog/suite` runs unless told (`-T suite=robocog-v2` or `robocog-v1` for the frozen ones).
SUITE = DEFAULT_SUITE


def names(value: Sequence[str] | str | None) -> list[str] | None:
    """A list of names from `-T` (a list, or one comma-separated string); None for none given."""
    if value is None:
        return None
    listed = value.split(",") if isinstance(value, str) else list(value)
    return [n.strip() for n in listed if n.strip()] or None


def suite_instances(
    suite: str = SUITE,
    split: str = "dev",
    families: Sequence[str] | str | None = None,
    capabilities: Sequence[str] | str | None = None,
    limit: int | None = None,
) -> list[Instance]:
    """The instances of a split of `suite`: of `families` (default all), carrying any of `capabilities`
    (default: any instance; only a tagged suite's instances carry capabilities), at most `limit`
    spread over the families (`robocog.shared.suite.select`). A ValueError names what is unknown."""
    generate_on_demand()  # a fresh split ("test@12345") missing from the cache
    manifest = load_suite(suite)
    wanted_families, wanted_capabilities = names(families), names(capabilities)
    unknown = sorted(set(wanted_families or []) - set(manifest.families))
    if unknown:
        raise ValueError(f"suite {suite}: no family {unknown}; its families: {', '.join(manifest.families)}")
    instances = load_split(suite, split)
    if wanted_capabilities is not None:
        if not manifest.tagged:
            raise ValueError(
                f"suite {suite} carries no capability tags (it predates them): filter it by families, "
                "or run a tagged suite (-T suite=robocog-v2)"
            )
        bad = sorted(set(wanted_capabilities) - set(CAPABILITIES))
        if bad:
            raise ValueError(f"no capability {bad}; the capabilities: {', '.join(CAPABILITIES)}")
        instances = [i for i in instances if set(i.capabilities) & set(wanted_capabilities)]
    chosen = select(instances, families=wanted_families, limit=limit)
    if not chosen:
        raise ValueError(f"suite {suite}, split {split}: no instance matches the families and capabilities given")
    return chosen


def split_metadata(suite: str, split: str) -> dict[str, object]:
    """What each sample of `split` of `suite` carries about it: a fresh split's names its suite SUITE@SEED,
    as its server does, and the folder its instances are in (`splits`, generated first if missing)."""
    name, seed = parse_split(split)
    generate_on_demand()
    fresh = fresh_split(suite, split)
    if fresh is None:
        return {"suite": suite, "split": name, "split_seed": None}
    server_suite, root = fresh
    return {"suite": server_suite, "split": name, "split_seed": seed, "splits": str(root)}


def instance_sample(instance: Instance, where: dict[str, object]) -> Sample:
    """The sample of one instance: its prompt, and what it is as metadata (`where`: `split_metadata`)."""
    return Sample(
        id=instance.id,
        input=instance.prompt,
        target="success",
        metadata={
            **where,
            "instance": instance.id,
            "family": instance.family,
            "variant": instance.variant,
            "capabilities": list(instance.capabilities),
            "feasible": instance.feasible,
            "optimal_steps": instance.optimal_steps,
            "scene": instance.scene,
            "earlier_tasks": [t.prompt for t in instance.prelude_tasks()],
        },
    )


@solver
def suite_agent(
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
    search_k: int | None = None,
) -> Solver:
    """One instance per sample on a fresh eval-profile server: the world set up for it, its earlier
    tasks run first (each its own episode and conversation, checked; one that fails fails the
    instance), then its own task through react(), and check_task's verdict. open and close are
    offered in a world with furniture that opens, as the robocog protocol does."""

    async def solve(state: TaskState, generate: Generate) -> TaskState:
        meta = state.metadata
        instance_id, suite = str(meta["instance"]), str(meta["suite"])
        data_dir = tempfile.mkdtemp(prefix="robocog-inspect-")
        try:
            server = robocog_server(data_dir, ["--splits", str(meta["splits"])] if meta.get("splits") else ())
            async with mcp_connection([server]):
                tools = {ToolDef(t).name: t for t in await server.tools()}  # controls too
                controls = controls_of(tools)
                world = await controls.reset_world(
                    instance=instance_id,
                    suite=suite,
                    memory_labels=memory_labels,
                    search_k=search_k if search_k is not None else PROTOCOL.search_k,
                )
                offered = list(ROBOT_TOOL_NAMES)
                if world.get("furniture"):
                    offered += sorted(FURNITURE_TOOLS & set(tools))
                pre_id: str | None = None
                try:
                    for n, prompt in enumerate(meta["earlier_tasks"], 1):
                        pre_id = f"{instance_id}-pre{n}"
                        async with span(pre_id, type="earlier task"):
                            await controls.begin_task(pre_id, keep_scratchpad=False)
                            messages: list[ChatMessage] = [ChatMessageUser(content=prompt)]
                            agent = robot_agent(server, prompt, max_invocations, offered)
                            pre = await agent(AgentState(messages=messages))
                            verdict = await controls.check_task(pre_id)
                        done = {"task": pre_id, "success": verdict.success, "believed": believed_status(pre.messages)}
                        state.store.set(SETUP_KEY, [*state.store.get(SETUP_KEY, []), done])
                        if not verdict.success:  # the instance would start where it should end: not run
                            why = f"its earlier task {pre_id} failed, so it was not run ({verdict.reason})"
                            state.store.set(VERDICT_KEY, {"task_id": instance_id, "success": False, "reason": why})
                            return state
                    pre_id = None
                finally:
                    if pre_id is not None and state.store.get(VERDICT_KEY) is None:  # a limit cut it short
                        why = f"a limit cut its earlier task {pre_id} short, so it was not run"
                        state.store.set(VERDICT_KEY, {"task_id": instance_id, "success": False, "reason": why})
                agent = robot_agent(server, state.input_text, max_invocations, offered)
                state = await judged_episode(state, generate, controls, instance_id, agent)
        finally:
            shutil.rmtree(data_dir, ignore_errors=True)
        return state

    return solve


@metric
def family() -> Metric:
    """The mean score of each family's samples (Inspect's `grouped` over the `family` metadata): in
    the log, `family_put_away`, ..."""
    per_family = cast(MetricProtocol, grouped(mean(), "family", all=False))  # as grouped() calls its metric

    def compute(scores: list[SampleScore]) -> Value:
        return per_family(scores)

    return compute


@metric
def capability() -> Metric:
    """The mean score of the samples carrying each capability tag (an instance counts under each of its
    tags; a sample without tags, as in robocog-v1, under none): in the log, `capability_memory`, ..."""

    def compute(scores: list[SampleScore]) -> Value:
        values: dict[str, list[float]] = {}
        for s in scores:
            for tag in (s.sample_metadata or {}).get("capabilities") or []:
                values.setdefault(str(tag), []).append(s.score.as_float())
        return {tag: sum(v) / len(v) for tag, v in sorted(values.items())}

    return compute


#: robocog/t1's metrics, with success per family and per capability, and false success per family.
SUITE_METRICS: dict[str, list[Metric]] = {
    **METRICS,
    "success": [*METRICS["success"], family(), capability()],
    "false_success": [*METRICS["false_success"], family(), capability()],
}


@scorer(metrics=SUITE_METRICS)
def suite_verdict() -> Scorer:
    """robocog/t1's score (the truth, the false success, the claim) of an instance: an infeasible
    instance's truth is its honest failure; an instance whose earlier task failed is a failure."""

    async def score(state: TaskState, target: Target) -> Score:
        return verdict_score(state)

    return score


@task
def suite(
    suite: str = SUITE,
    split: str = "dev",
    families: list[str] | str | None = None,
    capabilities: list[str] | str | None = None,
    limit: int | None = None,
    epochs: int = 1,
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
    message_limit: int | None = 600,
) -> Task:
    """The robocog suite: one sample per instance of `split` of `suite` (a fresh split: SPLIT@SEED), of
    `families` (a list, or a comma-separated string) carrying any of `capabilities` (a tagged suite's),
    at most `limit`, spread over the families. With `epochs` > 1 each sample reduces to the mean and to
    pass^k."""
    chosen = suite_instances(suite, split, families, capabilities, limit)
    where = split_metadata(suite, split)
    return Task(
        dataset=[instance_sample(i, where) for i in chosen],
        solver=suite_agent(max_invocations=max_invocations, memory_labels=memory_labels),
        scorer=suite_verdict(),
        epochs=Epochs(epochs, [mean_score(), pass_k(epochs)]) if epochs > 1 else 1,
        message_limit=message_limit,
    )
