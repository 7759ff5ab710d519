"""The scripted planner (the suite's oracle) as the outputs of Inspect's `mockllm/model`: an offline
model for any robocog task, e.g. `eval(suite(...), model=get_model("mockllm/model",
custom_outputs=planner_outputs()))`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from typing import Any

from inspect_ai.model import ChatMessage, ChatMessageAssistant, ChatMessageTool, GenerateConfig, ModelOutput
from inspect_ai.tool import ToolChoice, ToolInfo

from robocog.agent.policies.planner import Variant, decide

MODEL = "mockllm/model"


def as_openai(messages: Sequence[ChatMessage]) -> list[dict[str, Any]]:
    """Inspect's messages in the chat-completions form the planner reads."""
    out: list[dict[str, Any]] = []
    for m in messages:
        if isinstance(m, ChatMessageAssistant):
            calls = [
                {"id": c.id, "function": {"name": c.function, "arguments": json.dumps(c.arguments)}}
                for c in m.tool_calls or []
            ]
            out.append({"role": "assistant", "content": m.text, "tool_calls": calls})
        elif isinstance(m, ChatMessageTool):
            out.append({"role": "tool", "tool_call_id": m.tool_call_id, "content": m.text})
        else:
            out.append({"role": m.role, "content": m.text})
    return out


def planner_outputs(
    variant: Variant = "planner",
) -> Callable[[list[ChatMessage], list[ToolInfo], ToolChoice, GenerateConfig], ModelOutput]:
    """mockllm's `custom_outputs`: each turn, the planner's (or a variant's) next move for the
    conversation so far, a tool call or a plain answer. Stateless, so samples may run concurrently."""

    def output(
        messages: list[ChatMessage], tools: list[ToolInfo], tool_choice: ToolChoice, config: GenerateConfig
    ) -> ModelOutput:
        call = decide(as_openai(messages), variant)
        if call.name is None:
            return ModelOutput.from_content(model=MODEL, content=call.text)
        return ModelOutput.for_tool_call(model=MODEL, tool_name=call.name, tool_arguments=call.arguments)

    return output
