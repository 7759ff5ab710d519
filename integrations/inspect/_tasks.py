"""robocog as Inspect tasks: one sample is one episode on its own `robocog-server --profile eval`.

The solver opens the MCP connection for the whole episode (`mcp_connection`), sets the world up with
the eval profile's controls (reset_world, begin_task), runs Inspect's `react()` agent over
`mcp_tools(server, tools=ROBOT_TOOL_NAMES)` (the model never sees a control), stops when `end_task`
succeeds, and, still on the same connection, asks `check_task` for the ground truth.

Why the verdict is fetched by the solver and read by the scorer: Inspect runs a sample's solver in a
child task and its scorers in the parent task, and its stdio MCP sessions are per task, so a scorer
calling a tool of the same `MCPServer` object would start a second server process with a fresh
world. The episode's server lives exactly as long as the solver's `mcp_connection`; the solver's last
act on it is `check_task` (shielded from cancellation, so a time limit still gets a verdict), kept in
the sample's store. The scorer turns that verdict and the believed status (end_task's `status` in the
transcript) into the score, so `inspect score` can rescore a log without a server.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Awaitable, Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import anyio
from inspect_ai import Epochs, Task, task
from inspect_ai.agent import Agent, AgentPrompt, AgentState, as_solver, react
from inspect_ai.approval import Approval, ApprovalPolicy, Approver, approver
from inspect_ai.dataset import Sample
from inspect_ai.model import ChatMessage, ChatMessageAssistant
from inspect_ai.scorer import Metric, Score, Scorer, Target, accuracy, mean, mean_score, pass_k, scorer, stderr
from inspect_ai.solver import Generate, Solver, TaskState, solver
from inspect_ai.tool import (
    MCPServer,
    Tool,
    ToolCall,
    ToolCallView,
    ToolDef,
    ToolError,
    ToolSource,
    mcp_connection,
    mcp_server_stdio,
    mcp_tools,
)

from robocog.agent.policies.variants import decide
from robocog.agent.study_protocols import PROTOCOLS
from robocog.inspect._transcript import believed_status as believed_status  # the package's, from here
from robocog.inspect._transcript import ended, text_of
from robocog.shared.controls import EvalControls
from robocog.shared.protocol import PAPER_TOOLS, ROBOT_ID_ARG
from robocog.shared.tasks import TaskSpec, load_tasks

#: The eight tools offered to the model, in the paper's order (never a control, never the camera).
ROBOT_TOOL_NAMES: tuple[str, ...] = PAPER_TOOLS

#: Store keys the solver writes for the scorer.
VERDICT_KEY = "robocog:verdict"
SETUP_KEY = "robocog:setup"

#: The scene every sample runs in (the server's default, the paper's household).
SCENE = "household"

#: What a tool call after end_task in the same turn gets instead of running (as in `robocog run`).
NOT_RUN = "Not run: the task was ended with end_task."

#: The robocog protocol's messages (the paper's protocol stays in `robocog eval`; see docs/inspect.md).
PROTOCOL = PROTOCOLS["robocog"]


def offline_tokenizer() -> None:
    """Point tiktoken at the encodings LiteLLM (a robocog dependency) ships, unless set already.

    Inspect estimates token counts with tiktoken's o200k_base (its mockllm model does on every
    generate), which tiktoken otherwise downloads; LiteLLM bundles that file and sets the same
    variable itself when imported. So `--model mockllm/model` runs offline."""
    spec = importlib.util.find_spec("litellm")
    if spec is None or not spec.submodule_search_locations:
        return
    bundled = Path(next(iter(spec.submodule_search_locations))) / "litellm_core_utils" / "tokenizers"
    if bundled.is_dir():
        os.environ.setdefault("TIKTOKEN_CACHE_DIR", str(bundled))


offline_tokenizer()


@functools.cache
def task_specs() -> dict[str, TaskSpec]:
    """The tasks the server can check, from the package's assets."""
    with resources.as_file(resources.files("robocog.assets") / "tasks") as directory:
        return load_tasks(Path(directory))


def system_prompt() -> str:
    """The robocog protocol's system prompt (the text of the server's `robot_system` MCP prompt)."""
    path = resources.files("robocog.assets") / "prompts" / f"{PROTOCOL.system_prompt}.md"
    return path.read_text(encoding="utf-8").strip()


def server_command() -> str:
    """`robocog-server` beside this Python (Inspect may run without the venv on PATH)."""
    beside = Path(sys.executable).parent / "robocog-server"
    return str(beside) if beside.exists() else (shutil.which("robocog-server") or "robocog-server")


def robocog_server(data_dir: str | Path, extra_args: Sequence[str] = ()) -> MCPServer:
    """A `robocog-server --profile eval` over stdio with its own data directory."""
    return mcp_server_stdio(
        name="robocog",
        command=server_command(),
        args=["--profile", "eval", "--data-dir", str(data_dir), *extra_args],
        env={"ANONYMIZED_TELEMETRY": "False"},
    )


# --- the agent's loop, as react() hooks --------------------------------------------------------------


def stop_on_end_task(task_prompt: str, max_invocations: int) -> Callable[[AgentState], Awaitable[bool | str]]:
    """react's `on_continue`: stop once end_task ended the episode; a model that stops calling tools
    without it is re-invoked with the robocog protocol's reminder, up to `max_invocations` in all
    (then the episode is `stopped`, the paper's refusal), as `robocog run` does."""
    invocations = 1

    async def on_continue(state: AgentState) -> bool | str:
        nonlocal invocations
        if ended(state.messages):
            return False
        if state.output.message.tool_calls:
            return True
        if invocations >= max_invocations:
            return False
        invocations += 1
        return PROTOCOL.reinvocation_message(task_prompt, None)

    return on_continue


@approver
def nothing_after_end_task() -> Approver:
    """A call after end_task in the same turn is not run (it would begin a new episode)."""

    async def approve(message: str, call: ToolCall, view: ToolCallView, history: list[ChatMessage]) -> Approval:
        turn = next(
            (m for m in reversed(history) if isinstance(m, ChatMessageAssistant) and m.tool_calls),
            None,
        )
        calls = list(turn.tool_calls or []) if turn is not None else []
        ids = [c.id for c in calls]
        earlier = calls[: ids.index(call.id)] if call.id in ids else []
        if any(c.function == "end_task" for c in earlier):
            return Approval(decision="reject", explanation=NOT_RUN)
        return Approval(decision="approve")

    return approve


# --- the harness's calls on the episode's connection ------------------------------------------------


def controls_of(tools: dict[str, Tool]) -> EvalControls:
    """The eval controls through Inspect's MCP tools (a control's result is the JSON text the server sends)."""

    async def call(name: str, arguments: dict[str, Any]) -> dict[str, Any]:
        data = json.loads(text_of(await tools[name](**arguments)))
        if not isinstance(data, dict):
            raise RuntimeError(f"{name} answered {data!r}")
        return data

    return EvalControls(call)


async def play_planner(tools: dict[str, Tool], task_id: str, prompt: str, max_calls: int = 80) -> None:
    """Bring the world to the end of `task_id` with the scripted planner (harness-side, before the
    model's task begins; it stops short of end_task, so memory stays empty); raises if it did not."""
    controls = controls_of(tools)
    await controls.begin_task(task_id)
    messages: list[dict[str, Any]] = [{"role": "user", "content": prompt}]
    for n in range(max_calls):
        call = decide(messages)
        if call.name is None or call.name == "end_task":
            break
        try:
            content = text_of(await tools[call.name](**call.arguments))
        except ToolError as exc:
            content = str(exc)
        call_id = f"setup-{n}"
        function = {"name": call.name, "arguments": json.dumps(call.arguments)}
        messages.append({"role": "assistant", "content": "", "tool_calls": [{"id": call_id, "function": function}]})
        messages.append({"role": "tool", "tool_call_id": call_id, "content": content})
    verdict = await controls.check_task(task_id)
    if not verdict.success:
        raise RuntimeError(f"setting up: the planner did not complete {task_id}: {verdict.reason}")


async def judged_episode(
    state: TaskState, generate: Generate, controls: EvalControls, task_id: str, agent: Agent
) -> TaskState:
    """`task_id` begun, `agent` run as the sample's solver, and check_task's verdict kept in the store
    for the scorer: even when a limit cut the episode short (a time limit cancels: the verdict is
    asked shielded from it)."""
    await controls.begin_task(task_id, keep_scratchpad=False)
    try:
        state = await as_solver(agent)(state, generate)
    finally:
        with anyio.CancelScope(shield=True):
            state.store.set(VERDICT_KEY, (await controls.check_task(task_id)).model_dump())
    return state


# --- solver, scorer, tasks ---------------------------------------------------------------------------


def robot_agent(
    server: MCPServer, task_prompt: str, max_invocations: int, tool_names: Sequence[str] = ROBOT_TOOL_NAMES
) -> Agent:
    """Inspect's react() over `tool_names` of the episode's server, with the robocog system prompt: it
    stops once end_task ended the episode, and a call after end_task in the same turn is not run."""
    return react(
        prompt=AgentPrompt(
            instructions=system_prompt(), handoff_prompt=None, assistant_prompt=None, submit_prompt=None
        ),
        tools=[WithoutHandle(mcp_tools(server, tools=list(tool_names)))],
        submit=False,
        on_continue=stop_on_end_task(task_prompt, max_invocations),
        approval=[ApprovalPolicy(approver=nothing_after_end_task(), tools="*")],
    )


class WithoutHandle(ToolSource):
    """The server's tools as a model is offered them: without `robot_id`, the robot handle a client
    passes itself (over stdio, as here, the connection is the driver and no handle is needed)."""

    def __init__(self, source: ToolSource) -> None:
        self.source = source

    async def tools(self) -> list[Tool]:
        offered = []
        for tool in await self.source.tools():
            definition = ToolDef(tool)
            definition.parameters.properties.pop(ROBOT_ID_ARG, None)
            offered.append(definition.as_tool())
        return offered


@solver
def robocog_agent(
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
    search_k: int | None = None,
) -> Solver:
    """One episode per sample: a fresh eval-profile server, the world reset to the sample's seed, the
    task begun, react() over the eight robot tools until end_task, then check_task's verdict."""

    async def solve(state: TaskState, generate: Generate) -> TaskState:
        meta = state.metadata
        task_id = str(meta["task"])
        specs = task_specs()
        data_dir = tempfile.mkdtemp(prefix="robocog-inspect-")
        try:
            server = robocog_server(data_dir)
            async with mcp_connection([server]):
                tools = {ToolDef(t).name: t for t in await server.tools()}  # controls too
                controls = controls_of(tools)
                await controls.reset_world(
                    seed=int(meta["seed"]),
                    randomize=bool(meta.get("randomize", False)),
                    memory_labels=memory_labels,
                    search_k=search_k if search_k is not None else PROTOCOL.search_k,
                )
                for required in specs[task_id].requires:
                    await play_planner(tools, required, specs[required].prompt)
                    state.store.set(SETUP_KEY, [*state.store.get(SETUP_KEY, []), required])
                agent = robot_agent(server, specs[task_id].prompt, max_invocations)
                state = await judged_episode(state, generate, controls, task_id, agent)
        finally:
            shutil.rmtree(data_dir, ignore_errors=True)
        return state

    return solve


#: The metrics of a sample's score: the truth's accuracy, and the rates of the claims.
METRICS: dict[str, list[Metric]] = {
    "success": [accuracy(), stderr()],
    "false_success": [mean(), stderr()],
    "believed_success": [mean(), stderr()],
}


@scorer(metrics=METRICS)
def robocog_verdict() -> Scorer:
    """Ground truth (check_task, on the episode's own connection) against the believed status
    (end_task's): `success` (the truth), `false_success` (claimed success, truly failed: the paper's
    hallucinated success, over every attempt) and `believed_success` (claimed success; a never-ended
    episode claims nothing)."""

    async def score(state: TaskState, target: Target) -> Score:
        return verdict_score(state)

    return score


def verdict_score(state: TaskState) -> Score:
    """The score of a sample from the verdict its solver kept and the believed status in its transcript."""
    verdict = state.store.get(VERDICT_KEY)
    if not isinstance(verdict, dict):
        raise RuntimeError("no check_task verdict in the sample's store: the episode's server never answered")
    truth = bool(verdict["success"])
    believed = believed_status(state.messages)
    claimed = believed is True
    false = claimed and not truth
    return Score(
        value={"success": float(truth), "false_success": float(false), "believed_success": float(claimed)},
        answer={True: "success", False: "failure", None: "never ended"}[believed],
        explanation=str(verdict.get("reason", "")),
        metadata={
            "true_success": truth,
            "believed_success": believed,
            "agreement": claimed == truth,
            "outcome": "ended" if believed is not None else "stopped",
            "setup": state.store.get(SETUP_KEY, []),
        },
    )


def episodes(task_id: str, seeds: Sequence[int], randomize: bool) -> list[Sample]:
    """One sample per seed: an episode of `task_id` in the household scene."""
    spec = task_specs()[task_id]
    return [
        Sample(
            id=f"{task_id}-seed{seed}",
            input=spec.prompt,
            target="success",
            metadata={"task": task_id, "seed": seed, "scene": SCENE, "randomize": randomize},
        )
        for seed in seeds
    ]


def robocog_task(
    task_id: str,
    seeds: Sequence[int] = (0,),
    randomize: bool = False,
    epochs: int = 1,
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
    search_k: int | None = None,
    message_limit: int | None = 600,
) -> Task:
    """An Inspect task of one robocog task. With `epochs` > 1 each sample's score is reduced to the
    mean and to pass^k (k = epochs, Inspect's `pass_k`): every epoch is an independent episode on a
    new server with an empty memory."""
    if task_id not in task_specs():
        raise ValueError(f"no task {task_id!r} (there are {', '.join(task_specs())})")
    return Task(
        dataset=episodes(task_id, seeds, randomize),
        solver=robocog_agent(max_invocations=max_invocations, memory_labels=memory_labels, search_k=search_k),
        scorer=robocog_verdict(),
        epochs=Epochs(epochs, [mean_score(), pass_k(epochs)]) if epochs > 1 else 1,
        message_limit=message_limit,
    )


@task
def t1(
    seeds: list[int] | int = 0,
    randomize: bool = False,
    epochs: int = 1,
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
) -> Task:
    """T1 of the paper: put the mug, the box and the cube away into the kitchen shelf."""
    seeds = [seeds] if isinstance(seeds, int) else seeds
    return robocog_task("T1", seeds, randomize, epochs, max_invocations, memory_labels)


@task
def t2(
    seeds: list[int] | int = 0,
    randomize: bool = False,
    epochs: int = 1,
    max_invocations: int = 10,
    memory_labels: Literal["believed", "verified"] = "believed",
) -> Task:
    """T2 of the paper: swap the mug and the cube in the shelf. The world starts where T1 ends (the
    scripted planner plays T1 harness-side, without end_task, so memory starts empty)."""
    seeds = [seeds] if isinstance(seeds, int) else seeds
    return robocog_task("T2", seeds, randomize, epochs, max_invocations, memory_labels)
