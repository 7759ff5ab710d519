"""`make fuzz`: attack real `robocog-server --profile eval` processes and print the figures as JSON.

Stdio: `--calls` (25,000) random and hostile calls, one at a time, written as raw JSON-RPC lines so
that anything can be sent: valid actions, hostile arguments of every type (texts of up to 10 MB,
control characters, lone surrogates, huge numbers, NaN, deep nesting), unknown tools and methods,
odd resource URIs, random resets, begin_task and end_task, and lines that are not JSON-RPC at all.
After every call the world's ground truth (robocog://world/state) is checked against the invariants
of tests/integration/test_fuzz.py; a dead server is counted and started again. Per call: the wall time, and the
server's CPU time (utime + stime of /proc/PID/stat, all its threads) from sending to the answer.
RSS (VmRSS) is sampled every 1,000 calls.

HTTP: `--http-clients` (32) MCP clients at once, `--http-calls` (50) read-only calls each, against
`robocog-server --transport http` on a free loopback port: errors, p50/p99.

Not in `make bench` (which runs tests/bench/bench_*.py): 25,000 calls take minutes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import select
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import anyio

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from robocog.server.world.cstdio import stdout_to_stderr  # noqa: E402
from robocog.shared.results import WorldState  # noqa: E402
from tests.helpers import free_port, server_command  # noqa: E402
from tests.test_fuzz import MADE_UP_TOOLS, NUMBERS, ODD_TEXTS, PIECES, broken_invariants, repeat  # noqa: E402

#: Lengths of long texts, and how often each is drawn (10 MB: about once in 600 calls).
WIRE_SIZES = ((129, 30), (2_001, 30), (4_097, 20), (65_536, 10), (1 << 20, 4), (3 << 20, 2), (10 << 20, 1))
#: Longer than this without an answer, the server is hung (a 10 MB call included).
ANSWER_TIMEOUT_S = 120.0
#: The line naming an exception in a logged traceback.
ERROR_LINE = re.compile(r"^\W*[A-Za-z_.]*(Error|Exception|Exit|Interrupt)\b")
#: The deepest nesting of a message the SDK's JSON parser (pydantic-core) accepts.
JSON_NESTING = 200
#: Lines that are not a valid JSON-RPC request (each followed by a ping that must be answered).
RAW_LINES = (
    b"",
    b"{",
    b"null",
    b"[]",
    b"[1, 2, 3]",
    b'{"jsonrpc": "2.0"}',
    b'{"jsonrpc": "1.0", "id": 1, "method": "tools/list"}',
    b'{"jsonrpc": "2.0", "id": {"a": 1}, "method": "tools/list"}',
    b'{"jsonrpc": "2.0", "id": 7, "method": "tools/call", "params": [1, 2]}',
    b'{"jsonrpc": "2.0", "id": 8, "method": "tools/call", "params": "move_to"}',
    b'{"jsonrpc": "2.0", "id": 9, "method": "no/such/method", "params": {}}',
    b'{"jsonrpc": "2.0", "id": 10, "method": "initialize", "params": {}}',
    b'{"jsonrpc": "2.0", "method": "notifications/cancelled", "params": {"requestId": 123456}}',
    b'{"jsonrpc": "2.0", "id": 11, "method": "tools/call", "params": {"name": "grab", '
    b'"arguments": {"object": "\xff\xfe"}}}',
    b'{"jsonrpc": "2.0", "id": 12, "method": "tools/call", "params": {"name": "grab", "arguments": {"object": NaN}}}',
    b"\x00\x01\x02\xff",
)


def server_env() -> dict[str, str]:
    """The server's environment, without a token a developer may have set (the clients send none)."""
    env = {k: v for k, v in os.environ.items() if k != "ROBOCOG_AUTH_TOKEN"}
    return env | {"ANONYMIZED_TELEMETRY": "False", "COLUMNS": "240"}  # wide log lines: one record, one line


# --- the server's process -----------------------------------------------------------------------------


class Died(Exception):
    """The server's stdout closed, or it did not answer in time."""


def cpu_seconds(pid: int) -> float:
    """utime + stime of the process (all its threads), seconds."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return math.nan


class StdioServer:
    """`robocog-server --profile eval` over stdio, spoken to in raw JSON-RPC lines, one call at a time."""

    def __init__(self, data: Path, log: Path) -> None:
        self.log = log.open("ab")
        self.proc = subprocess.Popen(
            [*server_command(), "--profile", "eval", "--data-dir", str(data)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            env=server_env(),
        )
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.stdin = self.proc.stdin
        self.fd = self.proc.stdout.fileno()
        self.buffer = b""
        self.next_id = 0
        self.request(
            "initialize",
            {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "fuzz", "version": "1"}},
        )
        self.send_line(json.dumps({"jsonrpc": "2.0", "method": "notifications/initialized"}).encode())

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def send_line(self, line: bytes) -> None:
        try:
            self.stdin.write(line + b"\n")
            self.stdin.flush()
        except (BrokenPipeError, OSError) as exc:
            raise Died(f"writing: {exc}") from exc

    def encode(self, method: str, params: Any) -> tuple[int, bytes]:
        self.next_id += 1
        message = {"jsonrpc": "2.0", "id": self.next_id, "method": method, "params": params}
        return self.next_id, json.dumps(message).encode()  # NaN and lone surrogates go as Python writes them

    def request(self, method: str, params: Any) -> dict[str, Any]:
        request_id, line = self.encode(method, params)
        self.send_line(line)
        return self.answer(request_id)

    def answer(self, request_id: int) -> dict[str, Any]:
        """The response to `request_id`; notifications and other responses on the way are skipped."""
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        while True:
            while b"\n" not in self.buffer:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not select.select([self.fd], [], [], remaining)[0]:
                    raise Died(f"no answer to request {request_id} in {ANSWER_TIMEOUT_S:.0f} s")
                chunk = os.read(self.fd, 1 << 20)
                if not chunk:
                    raise Died("stdout closed")
                self.buffer += chunk
            line, self.buffer = self.buffer.split(b"\n", 1)
            if not line.strip():
                continue
            message = json.loads(line)
            if isinstance(message, dict) and message.get("id") == request_id and "method" not in message:
                return message

    def close(self) -> None:
        if self.alive():
            self.proc.kill()
        self.proc.wait()
        self.log.close()


# --- hostile calls ---------------------------------------------------------------------------------


@dataclass
class Scene:
    objects: list[str]
    locations: list[str]
    positions: list[tuple[str, str]]
    tools: dict[str, list[str]]  # tool -> its argument names


def text(r: random.Random) -> str:
    roll = r.random()
    if roll < 0.4:
        return r.choice(ODD_TEXTS)
    if roll < 0.7:  # any code point: control characters, surrogates, astral planes
        return "".join(chr(r.randrange(0x110000)) for _ in range(r.randrange(1, 40)))
    sizes, weights = zip(*WIRE_SIZES, strict=True)
    return repeat(r.choice(PIECES), r.choices(sizes, weights)[0])


def value(r: random.Random, depth: int = 0) -> Any:
    roll = r.random()
    if roll < 0.35:
        return text(r)
    if roll < 0.55:
        return r.choice(NUMBERS) if r.random() < 0.5 else r.randint(-(2**40), 2**40)
    if roll < 0.65:
        return r.choice([math.nan, math.inf, -math.inf, -0.0, 1e308, 5e-324, r.uniform(-1e6, 1e6)])
    if roll < 0.75:
        return r.choice([None, True, False])
    if roll < 0.9 and depth < 3:
        if r.random() < 0.5:
            return [value(r, depth + 1) for _ in range(r.randrange(5))]
        return {text(r)[:20]: value(r, depth + 1) for _ in range(r.randrange(5))}
    if roll < 0.95:
        nested: Any = []
        for _ in range(r.randrange(10, 400)):
            nested = [nested]
        return nested
    return ["mug"] * r.randrange(1_000, 300_000)


def name(r: random.Random, valid: list[str]) -> str:
    roll = r.random()
    chosen = r.choice(valid)
    if roll < 0.6:
        return chosen
    if roll < 0.7:
        return chosen.upper()
    if roll < 0.8:
        return f" {chosen}\t"
    return text(r)


def next_call(r: random.Random, scene: Scene) -> tuple[str, str, Any]:
    """(kind, label, params) of a random call: params of tools/call or resources/read, or raw bytes."""
    roll = r.random()
    if roll < 0.3:  # valid actions, so that the world moves through many states
        action = r.choice(["move_to", "grab", "place", "look_around"])
        if action == "move_to":
            return "action", action, {"name": action, "arguments": {"location": name(r, scene.locations)}}
        if action == "grab":
            return "action", action, {"name": action, "arguments": {"object": name(r, scene.objects)}}
        if action == "place":
            location, position = r.choice(scene.positions)
            return "action", action, {"name": action, "arguments": {"location": location, "position": position}}
        return "action", action, {"name": action, "arguments": {}}
    if roll < 0.4:
        control = r.choice(["reset_world", "begin_task", "end_task", "end_task", "check_task", "clear_memory"])
        by_control: dict[str, dict[str, Any]] = {
            "reset_world": {
                "seed": r.choice([None, r.randrange(2**32), r.choice(NUMBERS)]),
                "randomize": r.random() < 0.5,
            },
            "begin_task": {"task_id": r.choice(["T1", "T2", text(r)]), "keep_scratchpad": r.random() < 0.3},
            "end_task": {
                "status": r.choice(["success", "failure", text(r)]),
                "description": r.choice(["Put away all the items into the shelf.", text(r)]),
                "summary": r.choice(["done", text(r)]),
            },
            "check_task": {"task_id": r.choice(["T1", "T2", text(r)])},
            "clear_memory": {},
        }
        arguments = by_control[control]
        return "control", control, {"name": control, "arguments": arguments}
    if roll < 0.75:  # a published tool, each argument present or not, of any type; unknown arguments too
        tool = r.choice(sorted(scene.tools))
        arguments = {a: value(r) for a in scene.tools[tool] if r.random() < 0.7}
        if r.random() < 0.2:
            arguments[text(r)[:30]] = value(r)
        return "hostile", tool, {"name": tool, "arguments": arguments}
    if roll < 0.85:  # unknown tools, missing or non-object arguments
        tool = r.choice([*MADE_UP_TOOLS, *scene.tools, text(r)])
        params: dict[str, Any] = {"name": tool}
        if r.random() < 0.7:
            params["arguments"] = r.choice([None, [], "move_to", 3, {}, {"": value(r)}])
        return "unknown", tool if len(tool) < 40 else f"<{len(tool)} chars>", params
    if roll < 0.95:
        template = r.choice(["robocog://objects/{}", "robocog://locations/{}", "robocog://{}", "{}"])
        uri = template.format(name(r, scene.objects + scene.locations))
        return "resource", template, {"uri": uri}
    raw = r.choice(RAW_LINES)
    if r.random() < 0.2:
        depth = r.randrange(1_000, 100_000)
        raw = b'{"jsonrpc": "2.0", "id": 1, "method": "tools/call", "params": ' + b"[" * depth + b"]" * depth + b"}"
    elif r.random() < 0.1:
        raw = (
            b'{"jsonrpc": "2.0", "id": 2, "method": "tools/call", "params": {"name": "grab", "arguments": {"object": 1'
        )
        raw += b"0" * r.randrange(1_000, 1_000_000) + b"}}}"
    return "raw", "raw line", raw


# --- the stdio fuzz --------------------------------------------------------------------------------------


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


# --- HTTP: many clients at once ----------------------------------------------------------------------------


def start_http_server(work: Path) -> tuple[subprocess.Popen[bytes], str]:
    port = free_port()
    log = (work / "http.log").open("wb")
    command = [*server_command(), "--transport", "http", "--port", str(port), "--profile", "eval"]
    proc = subprocess.Popen(
        [*command, "--data-dir", str(work / "http-memory")], stdout=log, stderr=subprocess.STDOUT, env=server_env()
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"the HTTP server exited: {(work / 'http.log').read_text()}")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return proc, f"http://127.0.0.1:{port}/mcp"
        time.sleep(0.1)
    proc.kill()
    raise RuntimeError("the HTTP server did not listen within 60 s")


#: Read-only calls, so that no client needs to hold the robot (one session drives it at a time).
HTTP_CALLS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("look_around", {}),
    ("view_scratchpad", {}),
    ("search_memory", {"query": "Put away all the items into the shelf."}),
    ("resource", {"uri": "robocog://world/state"}),
)


async def http_clients(url: str, clients: int, calls: int) -> tuple[list[float], list[str]]:
    """`clients` MCP sessions at once, `calls` read-only calls each; (latencies, errors)."""
    from mcp import Client

    latencies: list[float] = []
    errors: list[str] = []

    async def one(index: int) -> None:
        try:
            async with Client(url) as client:
                for i in range(calls):
                    tool, arguments = HTTP_CALLS[(index + i) % len(HTTP_CALLS)]
                    start = time.perf_counter()
                    if tool == "resource":
                        await client.read_resource(arguments["uri"], cache_mode="bypass")
                    else:
                        result = await client.call_tool(tool, arguments)
                        if result.is_error:
                            errors.append(f"client {index} {tool}: {result.content}")
                    latencies.append(time.perf_counter() - start)
        except Exception as exc:  # boundary: every failure of a client is a figure
            errors.append(f"client {index}: {type(exc).__name__}: {exc}")

    async with anyio.create_task_group() as tg:
        for index in range(clients):
            tg.start_soon(one, index)
    return latencies, errors


async def warm_up(url: str) -> None:
    from mcp import Client

    async with Client(url) as client:
        await client.call_tool("look_around", {})  # waits for the world
        await client.call_tool("search_memory", {"query": "warm up"})  # loads the embedding model


def fuzz_http(clients: int, calls: int, work: Path) -> dict[str, Any]:
    proc, url = start_http_server(work)
    try:
        anyio.run(warm_up, url)
        start = time.perf_counter()
        latencies, errors = anyio.run(http_clients, url, clients, calls)
        wall = time.perf_counter() - start
        alive = proc.poll() is None
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    return {
        "http.clients": clients,
        "http.calls_per_client": calls,
        "http.calls_answered": len(latencies),
        "http.errors": len(errors),
        "http.call_p50_ms": round(percentile(latencies, 0.5) * 1e3, 2),
        "http.call_p99_ms": round(percentile(latencies, 0.99) * 1e3, 2),
        "http.calls_per_s": round(len(latencies) / wall, 1),
        "http.server_alive_after": alive,
        "http.first_errors": errors[:5],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calls", type=int, default=25_000, help="hostile calls over stdio (default: 25000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the calls' random generator (default: 0)")
    parser.add_argument("--http-clients", type=int, default=32, help="HTTP clients at once (default: 32)")
    parser.add_argument("--http-calls", type=int, default=50, help="calls per HTTP client (default: 50)")
    parser.add_argument("--only", choices=["stdio", "http"], default=None, help="run one of the two")
    args = parser.parse_args()
    if args.calls < 1000 or args.http_clients < 1 or args.http_calls < 1:
        parser.error("--calls must be at least 1000 (RSS is sampled every 1000), the HTTP counts at least 1")
    figures: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp, stdout_to_stderr():
        work = Path(tmp)
        if args.only in (None, "stdio"):
            started = time.perf_counter()
            figures |= fuzz_stdio(args.calls, args.seed, work)
            figures["fuzz.wall_s"] = round(time.perf_counter() - started, 1)
        if args.only in (None, "http"):
            figures |= fuzz_http(args.http_clients, args.http_calls, work)
    print(json.dumps(figures, indent=2, ensure_ascii=False))
    return 0 if not (figures.get("fuzz.server_deaths") or figures.get("fuzz.invariant_violations")) else 1


if __name__ == "__main__":
    sys.exit(main())
