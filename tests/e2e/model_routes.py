"""What the model-route tests share: the routes, the keys cleared before each test, T1 run as one
episode, a request's sampling parameters. Their fixtures are in tests/e2e/model_route_fixtures.py."""

from __future__ import annotations

from typing import Any

from robocog.agent.client.connection import Robot
from robocog.agent.client.loop import EpisodeResult, run_episode
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from tests.fake_llm import Request

ROUTES = ["openai/fake-model", "anthropic/claude-fake", "ollama_chat/fake-model"]
KEY_VARIABLES = ("OPENAI_API_KEY", "ANTHROPIC_API_KEY", "ANTHROPIC_AUTH_TOKEN", "OLLAMA_API_KEY")
HELLO = [{"role": "user", "content": "Hello."}]
END = ("end_task", {"status": "success", "description": "T1", "summary": "done"})


async def episode(robot: Robot, settings: AgentSettings, trace: Trace | None = None) -> tuple[EpisodeResult, bool]:
    """T1 from a fresh world and an empty memory; the result and the ground truth."""
    await robot.client.call_tool("clear_memory", {})
    await robot.client.call_tool("reset_world", {})
    result = await run_episode(
        robot.client,
        robot.tasks["T1"],
        settings,
        trace or Trace(),
        system_prompt=robot.system_prompt,
        tools=robot.tools,
    )
    checked = await robot.client.call_tool("check_task", {"task_id": "T1"})
    return result, bool((checked.structured_content or {}).get("success"))


def sampled(request: Request) -> dict[str, Any]:
    """The sampling parameters of a request (Ollama puts them under "options")."""
    body = request.body
    return dict(body.get("options", {})) if "options" in body else body
