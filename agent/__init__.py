"""The client side of robocog: drive the robot with any model over MCP, evaluate, report.

What a library user needs is exported here and imported on first use (the MCP SDK and LiteLLM take
seconds to import)::

    import anyio
    from robocog.agent import PROTOCOLS, AgentSettings, ServerSpec, Trace, connect, run_episode

    async def main() -> None:
        async with connect(ServerSpec()) as robot:  # spawns robocog-server over stdio
            result = await run_episode(
                robot.client,
                "Put away all the items into the shelf.",
                AgentSettings(model="scripted/planner"),
                Trace(None),
                system_prompt=await robot.prompt(PROTOCOLS["robocog"].system_prompt),
                tools=robot.tools,
            )
            print(result.outcome, result.believed_success, result.tool_calls)

    anyio.run(main)

The packages, one job each (their layers are checked by import-linter, see pyproject.toml):
`cli` (a module per command), `harness` (studies: units, the runner, fleets, Ray), `view` (the results
viewer), `contract` (the published MCP contract), `client` (connection, the lean MCP client for a
study's own servers, loop, model service, trace sinks), `suitegen` (the suite's generator), `analysis`
(results file, statistics, scores, taxonomy, figures, report), `policies` (the scripted models and the
planner), `families` (a suite family's draw and how the planner reads its prompts), `symbolic` (the
names-only world and the one optimal search), `study_protocols` (the `paper` and `robocog` protocols
as data).
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

# LiteLLM fetches its model cost map over the network at import unless told to use its local copy;
# every robocog.agent import runs this first. Chroma's telemetry stays off as well.
os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")
os.environ.setdefault("ANONYMIZED_TELEMETRY", "False")

if TYPE_CHECKING:
    from robocog.agent.client.connection import Robot, ServerSpec, connect
    from robocog.agent.client.loop import EpisodeResult, run_episode
    from robocog.agent.client.settings import AgentSettings
    from robocog.agent.client.trace_sinks import Trace
    from robocog.agent.harness.study import run_eval
    from robocog.agent.study_protocols import PROTOCOLS, EvalProtocol
    from robocog.shared.evaluation import AttemptRow, EvalConfig, load_config

#: Public name -> the module that defines it.
_EXPORTS = {
    "AgentSettings": "robocog.agent.client.settings",
    "ServerSpec": "robocog.agent.client.connection",
    "Robot": "robocog.agent.client.connection",
    "connect": "robocog.agent.client.connection",
    "run_episode": "robocog.agent.client.loop",
    "EpisodeResult": "robocog.agent.client.loop",
    "Trace": "robocog.agent.client.trace_sinks",
    "run_eval": "robocog.agent.harness.study",
    "EvalConfig": "robocog.shared.evaluation",
    "AttemptRow": "robocog.shared.evaluation",
    "load_config": "robocog.shared.evaluation",
    "PROTOCOLS": "robocog.agent.study_protocols",
    "EvalProtocol": "robocog.agent.study_protocols",
}

__all__ = [
    "PROTOCOLS",
    "AgentSettings",
    "AttemptRow",
    "EpisodeResult",
    "EvalConfig",
    "EvalProtocol",
    "Robot",
    "ServerSpec",
    "Trace",
    "connect",
    "load_config",
    "run_episode",
    "run_eval",
]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'robocog.agent' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
