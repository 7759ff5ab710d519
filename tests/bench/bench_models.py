"""Model-service figures, against the loopback fake model service (`tests/fake_llm/`):

- the client's own time per model turn (the loop's `complete()`: LiteLLM, the provider's SDK, the
  HTTP round trip on loopback), the fake server's own time on each request excluded
  (`Request.server_s`); beside it the floor (a bare httpx POST of the same body) and LiteLLM alone,
  so the part that is ours shows;
- the prompt tokens of one T1 episode along the planner's trajectory, counted with a real
  tokenizer (`litellm.token_counter` for gpt-4o) over every model call, with the share taken by the
  tool definitions, the system prompt and `look_around` results; for both protocols.

One T1 episode per route is run through the agent loop against a spawned robot server (the
planner's decisions replayed over HTTP) to record each call's messages; the calls are then replayed
`REPEATS` times, the variants interleaved call by call so that the machine's drift hits them alike.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # `tests.fake_llm`, when run as tests/bench/run.py
    sys.path.insert(0, str(ROOT))

import httpx  # noqa: E402
import litellm  # noqa: E402

from robocog.agent.client import loop  # noqa: E402
from robocog.agent.client import model as model_service  # noqa: E402
from robocog.agent.client.connection import ServerSpec, connect  # noqa: E402
from robocog.agent.client.loop import function_definitions, run_episode  # noqa: E402
from robocog.agent.client.model import PLACEHOLDER_KEY, assistant_message, complete, usage, warm_up_litellm  # noqa: E402
from robocog.agent.client.settings import AgentSettings  # noqa: E402
from robocog.agent.client.trace_sinks import Trace  # noqa: E402
from robocog.agent.study_protocols import PROTOCOLS, ProtocolName  # noqa: E402
from tests.fake_llm import FakeLLM, planner_script  # noqa: E402

ROUTES = {
    "openai": "openai/fake-model",  # through the OpenAI SDK
    "vllm": "hosted_vllm/fake-model",  # the same API through LiteLLM's own HTTP handler
    "anthropic": "anthropic/claude-fake",
    "ollama": "ollama_chat/fake-model",
}
REPEATS = 10
#: Idle after each call inside its CPU window: LiteLLM's success logging runs on its logging worker
#: after the call returns, and counts with the call that left it, not with the next one.
SETTLE_S = 0.005
TOKENIZER = "gpt-4o"

Call = tuple[list[dict[str, Any]], list[dict[str, Any]]]  # (messages, tools) of one model call


def _p(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


async def _record(robot: Any, settings: AgentSettings, protocol: ProtocolName = "robocog") -> list[Call]:
    """Run T1 once through the loop and return every model call's messages and tools."""
    calls: list[Call] = []
    real = loop.complete

    async def recording(s: AgentSettings, messages: list[dict[str, Any]], tools: list[dict[str, Any]]) -> Any:
        calls.append((json.loads(json.dumps(messages)), tools))
        return await real(s, messages, tools)

    loop.complete = recording  # type: ignore[assignment]
    try:
        await robot.client.call_tool("clear_memory", {})
        await robot.client.call_tool("reset_world", {})
        chosen = PROTOCOLS[protocol]
        result = await run_episode(
            robot.client,
            robot.tasks["T1"],
            settings,
            Trace(),
            system_prompt=await robot.prompt(chosen.system_prompt),
            tools=robot.tools,
            protocol=chosen,
        )
    finally:
        loop.complete = real
    checked = await robot.client.call_tool("check_task", {"task_id": "T1"})
    if result.outcome != "ended" or not (checked.structured_content or {}).get("success"):
        raise RuntimeError(f"T1 through {settings.model} did not succeed: {result}")
    return calls


async def _overhead(fake: FakeLLM, model: str, calls: list[Call]) -> dict[str, list[float]]:
    """Per call, seconds minus the server's own time: the loop's complete(), LiteLLM alone, a bare
    httpx POST of the body LiteLLM sent (the floor: loopback, HTTP, JSON); and the CPU time the
    loop's thread spent in complete() (`cpu`: what the machine's load does not inflate) and in
    LiteLLM alone with its defaults (`litellm_cpu`: it prices every response and builds a logging
    payload after it, which complete() spares it for a model not in its cost map, as these routes'
    fake models are not, and when no callback is registered), each with the work the call leaves
    to LiteLLM's logging worker (`SETTLE_S`)."""
    settings = AgentSettings(model=model, api_base=fake.api_base(model), seed=7)
    kwargs: dict[str, Any] = {"api_base": settings.api_base, "api_key": PLACEHOLDER_KEY, "max_retries": 0}
    out: dict[str, list[float]] = {"complete": [], "cpu": [], "litellm": [], "litellm_cpu": [], "httpx": []}
    async with httpx.AsyncClient() as client:
        for repeat in range(REPEATS + 1):
            for messages, tools in calls:
                fake.reset()
                cpu = time.thread_time()
                start = time.perf_counter()
                await complete(settings, messages, tools)
                t_complete = time.perf_counter() - start - fake.last.server_s
                await asyncio.sleep(SETTLE_S)
                t_cpu = time.thread_time() - cpu
                sent = fake.last
                fake.reset()
                cpu = time.thread_time()
                start = time.perf_counter()
                await litellm.acompletion(
                    model=model, messages=messages, tools=tools, seed=7, drop_params=True, **kwargs
                )
                t_litellm = time.perf_counter() - start - fake.last.server_s
                await asyncio.sleep(SETTLE_S)
                t_litellm_cpu = time.thread_time() - cpu
                fake.reset()
                start = time.perf_counter()
                response = await client.post(fake.url + sent.path, json=sent.body, headers={"x-api-key": "k"})
                response.json()
                t_httpx = time.perf_counter() - start - fake.last.server_s
                if repeat:  # the first pass warms every path up
                    out["complete"].append(t_complete)
                    out["cpu"].append(t_cpu)
                    out["litellm"].append(t_litellm)
                    out["litellm_cpu"].append(t_litellm_cpu)
                    out["httpx"].append(t_httpx)
    return out


def _ours(model: str, calls: list[Call], response: Any) -> float:
    """Microseconds of robocog's own work around one LiteLLM call (arguments: dropped parameters,
    key, pricing; reading the response), the median over many."""
    settings = AgentSettings(model=model, api_base="http://127.0.0.1:9/v1", seed=7, temperature=0.6)
    times = []
    for _ in range(2000):
        start = time.perf_counter()
        model_service._call_arguments(settings)
        model_service._priced(model)
        assistant_message(response)
        usage(response)
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


def _offline_response_us(message: dict[str, Any]) -> dict[str, float]:
    """Microseconds to build one offline model's response (what `complete()` returns for
    `scripted/...`, without LiteLLM), beside LiteLLM's `ModelResponse` of the same turn (what the
    offline models answer through LiteLLM itself), the median over many."""
    from robocog.agent.policies.offline import response
    from robocog.agent.policies.providers import model_response

    out = {}
    for name, build in (
        ("offline", lambda: response("scripted/planner", message, 8000, 0.0)),
        ("litellm", lambda: model_response("scripted/planner", message, 8000)),
    ):
        times = []
        for _ in range(2000):
            start = time.perf_counter()
            build()
            times.append(time.perf_counter() - start)
        out[f"models.response_build.{name}_us"] = round(statistics.median(times) * 1e6, 1)
    return out


def _tokens(calls: list[Call]) -> dict[str, float]:
    """Prompt tokens summed over the episode's calls, and the shares of what makes them up."""
    total = without_tools = system = looks = 0
    for messages, tools in calls:
        with_tools = litellm.token_counter(model=TOKENIZER, messages=messages, tools=tools)  # type: ignore[arg-type]
        bare = litellm.token_counter(model=TOKENIZER, messages=messages)
        total += with_tools
        without_tools += bare
        system += sum(
            litellm.token_counter(model=TOKENIZER, text=m["content"]) for m in messages if m["role"] == "system"
        )
        look_ids = {
            c["id"]
            for m in messages
            if m["role"] == "assistant"
            for c in m.get("tool_calls") or []
            if c["function"]["name"] == "look_around"
        }
        looks += sum(
            litellm.token_counter(model=TOKENIZER, text=m["content"])
            for m in messages
            if m["role"] == "tool" and m.get("tool_call_id") in look_ids
        )
    definitions = total - without_tools
    last = litellm.token_counter(model=TOKENIZER, messages=calls[-1][0], tools=calls[-1][1])  # type: ignore[arg-type]
    return {
        "calls": len(calls),
        "prompt_tokens": total,
        "per_call_mean": round(total / len(calls), 1),
        "last_call": last,
        "tool_definitions_tokens_per_call": round(definitions / len(calls), 1),
        "tool_definitions_share": round(definitions / total, 3),
        "system_prompt_share": round(system / total, 3),
        "look_around_results_share": round(looks / total, 3),
    }


async def _main() -> dict[str, Any]:
    out: dict[str, Any] = {}
    warm_up_litellm(ROUTES.values())
    with tempfile.TemporaryDirectory() as tmp, FakeLLM(planner_script()) as fake:
        spec = ServerSpec(extra_args=["--profile", "eval", "--data-dir", f"{tmp}/memory"])
        async with connect(spec) as robot:
            for route, model in ROUTES.items():
                settings = AgentSettings(model=model, api_base=fake.api_base(model), seed=7)
                calls = await _record(robot, settings)
                times = await _overhead(fake, model, calls)
                prefix = f"models.{route}.turn_overhead"
                for variant, values in times.items():
                    out[f"{prefix}.{variant}_p50_ms"] = round(_p(values, 0.5) * 1e3, 2)
                out[f"{prefix}.complete_p90_ms"] = round(_p(times["complete"], 0.9) * 1e3, 2)
                messages, tools = calls[-1]
                response = await complete(settings, messages, tools)
                out[f"{prefix}.robocog_own_us"] = round(_ours(model, calls, response), 1)
                if route == "openai":
                    out.update(_offline_response_us(assistant_message(response)))
                if route == "openai":
                    first = [t for i, t in enumerate(times["complete"]) if i % len(calls) == 0]
                    last = [t for i, t in enumerate(times["complete"]) if i % len(calls) == len(calls) - 1]
                    out[f"{prefix}.first_call_p50_ms"] = round(statistics.median(first) * 1e3, 2)
                    out[f"{prefix}.last_call_p50_ms"] = round(statistics.median(last) * 1e3, 2)
            openai = ROUTES["openai"]
            protocols: tuple[ProtocolName, ...] = ("robocog", "paper")
            for protocol in protocols:
                calls = await _record(robot, AgentSettings(model=openai, api_base=fake.api_base(openai)), protocol)
                for key, value in _tokens(calls).items():
                    out[f"models.t1_tokens.{protocol}.{key}"] = value
            out["models.tool_definitions"] = len(function_definitions(robot.tools))
    out["models.turn_overhead_samples"] = REPEATS
    out["models.target_turn_overhead_p50_ms"] = 5.0
    return out


def run() -> dict[str, Any]:
    litellm.suppress_debug_info = True
    return asyncio.run(_main())


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
