"""A unit's controls (`Runner.run_unit`): the first reset clears the unit's namespace (no
`clear_memory` call of its own) and the unit's last check writes no verdict into the record the unit
drops next (the client and its server ship together: no calls for older contracts). An in-process
server of the eval profile."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.client.connection import ServerSpec, _robot
from robocog.agent.harness.runner import Runner
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.evaluation import AttemptRow, EvalConfig, ModelSpec

pytestmark = pytest.mark.anyio

CONTROLS = ("reset_world", "clear_memory", "begin_task", "check_task")


async def run_unit(tmp_path: Path, **overrides: Any) -> tuple[list[tuple[str, dict[str, Any]]], list[AttemptRow]]:
    """One unit (T1 then T2, two memory iterations): the controls it called, in order, with their
    arguments, and its rows."""
    settings: dict[str, Any] = {
        "name": "units",
        "models": [ModelSpec(model="scripted/planner")],
        "tasks": ["T1", "T2"],
        "trials": 1,
        "memory_iterations": 2,
    }
    config = EvalConfig.model_validate(settings | overrides)
    out = tmp_path / "rows.jsonl"
    out.parent.mkdir(parents=True, exist_ok=True)
    runner = Runner(config, out)
    calls: list[tuple[str, dict[str, Any]]] = []
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server, raise_exceptions=True) as client:
        call_tool = client.call_tool

        async def recorded(name: str, arguments: dict[str, Any] | None = None, *args: Any, **kwargs: Any) -> Any:
            if name in CONTROLS:
                calls.append((name, dict(arguments or {})))
            return await call_tool(name, arguments, *args, **kwargs)

        client.call_tool = recorded  # type: ignore[method-assign]
        robot = await _robot(client, (await client.list_tools()).tools, ServerSpec())
        assert await runner.run_unit(robot, config.models[0], trial=0, start_iteration=0) is None
    rows = [AttemptRow.model_validate_json(line) for line in out.read_text(encoding="utf-8").splitlines()]
    return calls, rows


async def test_a_unit_clears_with_its_first_reset_and_records_no_verdict_it_drops(tmp_path: Path) -> None:
    calls, rows = await run_unit(tmp_path)
    resets = [args for name, args in calls if name == "reset_world"]
    assert [r.get("clear_memory") for r in resets] == [True, None]  # iteration 0 only
    assert [args for name, args in calls if name == "clear_memory"] == [{"drop": True}]  # the unit's end only
    checks = [args for name, args in calls if name == "check_task"]
    assert [(c["task_id"], c.get("record")) for c in checks] == [
        ("T1", None),
        ("T2", None),
        ("T1", None),
        ("T2", False),
    ]
    assert [(r.memory_iteration, r.task, r.true_success) for r in rows] == [
        (0, "T1", True),
        (0, "T2", True),
        (1, "T1", True),
        (1, "T2", True),
    ]


async def test_a_unit_that_keeps_its_memory_writes_every_verdict(tmp_path: Path) -> None:
    calls, _ = await run_unit(tmp_path, keep_memory=True)
    assert not any("record" in args for name, args in calls if name == "check_task")
    assert not any(name == "clear_memory" for name, _ in calls)
