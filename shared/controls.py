"""The eval profile's harness controls as one typed client: reset_world, begin_task, check_task,
clear_memory.

Whatever carries a call (the MCP SDK's `Client`, Inspect's tools), `EvalControls` names the controls,
their arguments and what they answer, so the evaluation harness (`robocog.agent.harness`), the
Inspect tasks (`robocog.inspect`) and the pytest plugin (`robocog.server.testing`) call them alike.
A transport is a `ControlCall`: the control's name and its arguments in, its structured result out
(or an exception naming the control). `mcp_call` adapts an MCP client session.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any, Literal

from robocog.shared.perturbations import Perturbation
from robocog.shared.results import TaskVerdict

#: Call one control with its arguments; answers its structured result (raises on a tool error).
ControlCall = Callable[[str, dict[str, Any]], Awaitable[dict[str, Any]]]


def mcp_call(client: Any, error: type[Exception] = RuntimeError) -> ControlCall:
    """A `ControlCall` over an MCP client (anything with the SDK's `call_tool(name, arguments)`): a tool
    error, or a result without structured content, raises `error` with the control's name and text."""

    async def call(tool: str, arguments: dict[str, Any]) -> dict[str, Any]:
        result = await client.call_tool(tool, arguments)
        if result.is_error or not isinstance(result.structured_content, dict):
            text = " ".join(getattr(b, "text", "") for b in result.content)
            raise error(f"{tool} failed: {text}")
        return dict(result.structured_content)

    return call


class EvalControls:
    """The four controls of the eval profile, typed. Arguments left at None are not sent (the server's
    default, or what an earlier reset set, holds)."""

    def __init__(self, call: ControlCall) -> None:
        self._call = call

    async def reset_world(
        self,
        *,
        seed: int | None = None,
        randomize: bool = False,
        memory_labels: Literal["believed", "verified"] | None = None,
        search_k: int | None = None,
        memory_namespace: str | None = None,
        instance: str | None = None,
        suite: str | None = None,
        observe: Literal["location", "room", "house"] | None = None,
        perturbations: list[Perturbation] | None = None,
        clear_memory: bool = False,
    ) -> dict[str, Any]:
        """The start state again (a new episode), or a suite instance's start; answers the world state.
        `observe`, when given, is what look_around reveals from now on (contract 3.1); `perturbations`,
        what goes wrong in this episode (contract 3.2); `clear_memory`, the namespace's records
        forgotten first (contract 3.3: sent only when true)."""
        arguments: dict[str, Any] = {"seed": seed, "randomize": randomize}
        optional = {
            "memory_labels": memory_labels,
            "search_k": search_k,
            "memory_namespace": memory_namespace,
            "instance": instance,
            "suite": suite,
            "observe": observe,
            "perturbations": None
            if perturbations is None
            else [p.model_dump(mode="json", exclude_defaults=True) | {"kind": p.kind} for p in perturbations],
            "clear_memory": True if clear_memory else None,
        }
        arguments.update({k: v for k, v in optional.items() if v is not None})
        if instance is not None:  # an instance sets its own start: no seed or randomization of ours
            arguments.pop("seed")
            arguments.pop("randomize")
        return await self._call("reset_world", arguments)

    async def begin_task(
        self, task_id: str, *, keep_scratchpad: bool = False, episode_id: str | None = None
    ) -> dict[str, Any]:
        """A new episode for `task_id`: the world as it is now is what check_task judges against."""
        arguments: dict[str, Any] = {"task_id": task_id, "keep_scratchpad": keep_scratchpad}
        if episode_id is not None:
            arguments["episode_id"] = episode_id
        return await self._call("begin_task", arguments)

    async def check_task(self, task_id: str, *, record: bool = True) -> TaskVerdict:
        """The ground-truth verdict of `task_id` against the episode's start; with `record` false (contract
        3.3: sent only then), not written into the episode's memory record."""
        arguments: dict[str, Any] = {"task_id": task_id} if record else {"task_id": task_id, "record": False}
        return TaskVerdict.model_validate(await self._call("check_task", arguments))

    async def clear_memory(self, *, drop: bool = False) -> int:
        """Forget every record of the memory namespace (with `drop`, delete the namespace and its files,
        and go back to the server's own); answers how many records were removed."""
        return int((await self._call("clear_memory", {"drop": True} if drop else {}))["removed"])
