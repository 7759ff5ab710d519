"""The scripted planner (the suite's oracle) as an Inspect model, offline: the model provider
`robocog` (`--model robocog/planner`, or a variant: `robocog/overconfident`, `robocog/refuser`, as
`robocog run --model scripted/...`), and the outputs of Inspect's `mockllm/model`
(`get_model("mockllm/model", custom_outputs=planner_outputs())`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from typing import Any

from inspect_ai.model import (
    ChatMessage,
    ChatMessageAssistant,
    ChatMessageTool,
    GenerateConfig,
    ModelAPI,
    ModelOutput,
    modelapi,
)
from inspect_ai.tool import ToolChoice, ToolInfo

from robocog.agent.policies.variants import VARIANTS, Variant, decide

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
            # A tool that failed (the server's isError: a blocked corridor, a position out of reach) has
            # its result in `error`, not in the content: the planner must read it all the same.
            text = m.text or (m.error.message if m.error is not None else "")
            out.append({"role": "tool", "tool_call_id": m.tool_call_id, "content": text})
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


class PlannerAPI(ModelAPI):
    """The planner (or a variant, the model's name) as a model provider: each turn its next move."""

    def __init__(
        self,
        model_name: str,
        base_url: str | None = None,
        api_key: str | None = None,
        config: GenerateConfig | None = None,
        **model_args: Any,
    ) -> None:
        super().__init__(model_name, base_url, api_key, [], config or GenerateConfig())
        variant = next((v for v in VARIANTS if v == model_name), None)
        if variant is None:
            raise ValueError(f"no robocog model {model_name!r}: robocog/{', robocog/'.join(VARIANTS)}")
        self.outputs = planner_outputs(variant)

    async def generate(
        self, input: list[ChatMessage], tools: list[ToolInfo], tool_choice: ToolChoice, config: GenerateConfig
    ) -> ModelOutput:
        return self.outputs(input, tools, tool_choice, config)


@modelapi(name="robocog")
def robocog_planner() -> type[ModelAPI]:
    """Inspect's model provider `robocog`: `--model robocog/planner` (or `overconfident`, `refuser`)."""
    return PlannerAPI
