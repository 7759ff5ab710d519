"""Random and hostile calls for the stdio fuzz: valid actions, controls, a published tool with
arguments of any type, unknown tools, odd resource URIs, and raw lines that are not JSON-RPC."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from typing import Any

from tests.hostile_inputs import MADE_UP_TOOLS, NUMBERS, ODD_TEXTS, PIECES, repeat

#: Lengths of long texts, and how often each is drawn (10 MB: about once in 600 calls).
WIRE_SIZES = ((129, 30), (2_001, 30), (4_097, 20), (65_536, 10), (1 << 20, 4), (3 << 20, 2), (10 << 20, 1))
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
