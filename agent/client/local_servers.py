"""What a local OpenAI-compatible server (llama.cpp, vLLM, LM Studio) is sent differently from a cloud
API: the one adaptation of the tool definitions themselves (`robocog.agent.client.model.sendable_request`
makes the others)."""

from __future__ import annotations

from typing import Any

#: The longest `maxLength` a local OpenAI-compatible server is sent. llama.cpp turns a tool's schema
#: into a grammar that repeats a rule `maxLength` times, and refuses past 2,000 repetitions ("number of
#: rules that are going to be repeated ... exceeds sane defaults"); llama-cpp-python's server then
#: dies. robocog's texts (a scratchpad note, end_task's summary, a memory query) allow 2,000-4,000.
LOCAL_MAX_LENGTH = 1000
#: The routes by which a server given by `api_base` is an OpenAI-compatible one (llama.cpp, vLLM, LM Studio).
OPENAI_COMPATIBLE = frozenset({"openai", "hosted_vllm"})


def bounded(value: Any) -> Any:
    """`value` (a tool definition, or a part of one) without a `maxLength` above `LOCAL_MAX_LENGTH`."""
    if isinstance(value, dict):
        too_long = isinstance(value.get("maxLength"), int) and value["maxLength"] > LOCAL_MAX_LENGTH
        return {k: bounded(v) for k, v in value.items() if not (too_long and k == "maxLength")}
    if isinstance(value, list):
        return [bounded(v) for v in value]
    return value
