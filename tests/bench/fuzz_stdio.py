"""The stdio fuzz: hostile calls one at a time, the world's invariants checked after each, a dead
server counted and started again; the figures (latency, CPU per call, RSS, outcomes) summarised."""

from __future__ import annotations

import json
import math
import os
import random
import re
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robocog.shared.results import WorldState
from tests.bench.fuzz_calls import Scene, next_call
from tests.bench.fuzz_server_process import Died, StdioServer, cpu_seconds, rss_mb
from tests.world_invariants import broken_invariants

#: The line naming an exception in a logged traceback.
ERROR_LINE = re.compile(r"^\W*[A-Za-z_.]*(Error|Exception|Exit|Interrupt)\b")
#: The deepest nesting of a message the SDK's JSON parser (pydantic-core) accepts.
JSON_NESTING = 200


@dataclass
class Figures:
    calls: int = 0
    deaths: list[str] = field(default_factory=list)
    violations: list[str] = field(default_factory=list)
    tracebacks: list[str] = field(default_factory=list)
    latencies: list[float] = field(default_factory=list)
    #: (s, kind, label, request bytes, the call before)
    cpu: list[tuple[float, str, str, int, str]] = field(default_factory=list)
    rss: list[tuple[int, float]] = field(default_factory=list)  # (calls so far, MB)
    outcomes: Counter[str] = field(default_factory=Counter)


def read_scene(server: StdioServer) -> Scene:
    tools = server.request("tools/list", {})["result"]["tools"]
    world_map = json.loads(
        server.request("resources/read", {"uri": "robocog://world/map"})["result"]["contents"][0]["text"]
    )
    state = world_state(server)
    return Scene(
        objects=sorted(o.object for o in state.objects),
        locations=sorted(loc["name"] for loc in world_map["locations"]),
        positions=sorted((p["location"], p["position"]) for p in world_map["place_positions"]),
        tools={t["name"]: sorted(t["inputSchema"].get("properties", {})) for t in tools},
    )


def world_state(server: StdioServer) -> WorldState:
    answer = server.request("resources/read", {"uri": "robocog://world/state"})
    return WorldState.model_validate_json(answer["result"]["contents"][0]["text"])


def outcome(answer: dict[str, Any] | None) -> tuple[str, str]:
    """('result' | 'tool error' | 'rpc error' | 'no answer, ping answered', the text a client reads)."""
    if answer is None:
        return "no answer, ping answered", ""
    if "error" in answer:
        return "rpc error", json.dumps(answer["error"])
    result = answer.get("result", {})
    text = json.dumps(result)
    return ("tool error" if result.get("isError") else "result"), text


def fuzz_stdio(calls: int, seed: int, work: Path) -> dict[str, Any]:
    r = random.Random(seed)
    figures = Figures()
    log = work / "server.log"
    server = StdioServer(work / "memory", log)
    server.request("tools/call", {"name": "look_around", "arguments": {}})  # waits for the world
    scene = read_scene(server)
    started = time.perf_counter()
    previous = ""
    while figures.calls < calls:
        kind, label, params = next_call(r, scene)
        figures.calls += 1
        try:
            cpu_before = cpu_seconds(server.pid)
            start = time.perf_counter()
            answer, size = exchange(server, kind, params)
            elapsed = time.perf_counter() - start
            cpu = cpu_seconds(server.pid) - cpu_before
            figures.latencies.append(elapsed)
            figures.cpu.append((cpu, kind, label, size, previous))
            previous = f"{kind} {label} ({size} bytes)"
            what, text = outcome(answer)
            figures.outcomes[f"{kind}: {what}"] += 1
            if "Traceback" in text:
                figures.tracebacks.append(f"call {figures.calls} {kind} {label}: {text[:300]}")
            problems = broken_invariants(world_state(server), scene.objects, scene.locations)
            if problems:
                figures.violations.append(f"after call {figures.calls} {kind} {label}: {'; '.join(problems)}")
                server.request("tools/call", {"name": "reset_world", "arguments": {"seed": 0}})
        except Died as exc:
            figures.deaths.append(f"call {figures.calls} {kind} {label} ({len(str(params))} chars): {exc}")
            print(f"fuzz: the server died: {figures.deaths[-1]}", file=sys.stderr, flush=True)
            server.close()
            server = StdioServer(work / "memory", log)
            server.request("tools/call", {"name": "look_around", "arguments": {}})
        if figures.calls % 1000 == 0:
            figures.rss.append((figures.calls, rss_mb(server.pid)))
            print(f"fuzz: {figures.calls} calls, {time.perf_counter() - started:.0f} s", file=sys.stderr, flush=True)
    server.close()
    return summarise(figures, log)


def exchange(server: StdioServer, kind: str, params: Any) -> tuple[dict[str, Any] | None, int]:
    """Send one call and wait for its answer: (the answer, or None when none is due; bytes sent).

    A raw line, and a request the SDK's stdio transport drops without an answer (a lone surrogate,
    which JSON can escape but UTF-8 cannot carry; nesting deeper than its parser's limit), are
    followed by a ping, which must be answered."""
    if kind == "raw":
        line: bytes = params
    else:
        request_id, line = server.encode("resources/read" if kind == "resource" else "tools/call", params)
    server.send_line(line)
    if kind != "raw" and not lone_surrogates(params) and nesting(params) + 1 <= JSON_NESTING:
        return server.answer(request_id), len(line)
    ping_id, ping = server.encode("ping", {})
    server.send_line(ping)
    server.answer(ping_id)
    return None, len(line)


def nesting(value: Any) -> int:
    """How deep lists and objects nest in `value` (a scalar: 0)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            children = item.values() if isinstance(item, dict) else item
            deepest = max(deepest, depth + 1)
            stack.extend((child, depth + 1) for child in children)
    return deepest


def lone_surrogates(params: Any) -> bool:
    """Whether a text in `params` holds a lone surrogate (JSON can escape one; UTF-8 cannot carry it)."""
    try:
        json.dumps(params, ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError:
        return True
    except (TypeError, ValueError):  # bytes of a raw line
        return False
    return False


def percentile(values: list[float], q: float) -> float:
    """The `q` quantile of `values` (NaN for none)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else math.nan


def summarise(figures: Figures, log: Path) -> dict[str, Any]:
    logged = log.read_text(errors="replace")
    worst = sorted(figures.cpu, reverse=True)[:5]
    small = [c for c in figures.cpu if c[3] <= 65_536]
    over_50ms = Counter(
        f"{kind} {label}{' (>64 KB)' if n > 65_536 else ''}" for cpu, kind, label, n, _ in figures.cpu if cpu > 0.05
    )
    lines = logged.splitlines()
    unexpected = [
        " ".join(line.split()[-12:]) + " | " + next((e.strip() for e in lines[i : i + 80] if ERROR_LINE.match(e)), "?")
        for i, line in enumerate(lines)
        if "unexpected exception" in line
    ]
    # RSS growth from the first sample (the embedding model and the world are loaded by then) to the last.
    (first_calls, first_mb), (last_calls, last_mb) = figures.rss[0], figures.rss[-1]
    growth = (last_mb - first_mb) / max(1, last_calls - first_calls) * 1000
    return {
        "fuzz.calls_sent": figures.calls,
        "fuzz.server_deaths": len(figures.deaths),
        "fuzz.invariant_violations": len(figures.violations),
        "fuzz.tracebacks_to_client": len(figures.tracebacks),
        "fuzz.unexpected_exceptions_logged": len(unexpected),
        "fuzz.unexpected_exceptions": unexpected[:5],
        "fuzz.call_p50_ms": round(percentile(figures.latencies, 0.5) * 1e3, 2),
        "fuzz.call_p99_ms": round(percentile(figures.latencies, 0.99) * 1e3, 2),
        "fuzz.call_max_ms": round(max(figures.latencies) * 1e3, 1),
        "fuzz.rss_first_sample_mb": round(first_mb, 1),
        "fuzz.rss_last_sample_mb": round(last_mb, 1),
        "fuzz.rss_growth_per_1000_calls_mb": round(growth, 2),
        "fuzz.max_call_cpu_ms": round(worst[0][0] * 1e3, 1),
        "fuzz.max_call_cpu_requests_under_64kb_ms": round(max(c[0] for c in small) * 1e3, 1),
        "fuzz.call_cpu_p99_ms": round(percentile([c[0] for c in figures.cpu], 0.99) * 1e3, 1),
        "fuzz.max_call_cpu_goal_ms": 50,
        "fuzz.calls_over_50ms_cpu": sum(1 for c in figures.cpu if c[0] > 0.05),
        "fuzz.calls_over_50ms_cpu_by_call": dict(over_50ms.most_common(8)),
        "fuzz.cpu_clock_tick_ms": round(1e3 / os.sysconf("SC_CLK_TCK"), 1),
        "fuzz.costliest_calls": [
            {"cpu_ms": round(c * 1e3, 1), "kind": k, "call": label, "request_bytes": n, "after": before}
            for c, k, label, n, before in worst
        ],
        "fuzz.outcomes": dict(sorted(figures.outcomes.items())),
        "fuzz.deaths": figures.deaths[:5],
        "fuzz.violations": figures.violations[:5],
        "fuzz.tracebacks": figures.tracebacks[:5],
    }
