"""Benchmark of embeddings and episodic memory (not a pytest module).

Run: ``.venv/bin/python tests/bench/bench_memory.py``. Targets: search p50 <= 10 ms and
add p50 <= 20 ms with 10,000 records. And a study unit's memory work (its namespace opened, searched,
written, given its verdict, counted and dropped) with the data directory's Chroma client kept running
between namespaces (`chroma.EMBEDDED`) against a client started and stopped for each namespace (as
before), and kept with the data directory on the RAM file system a study keeps its servers' memory in
(`robocog.agent.harness.scratch`), in alternating rounds, in a process of its own (`--units`).
"""

from __future__ import annotations

import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

from robocog.server.memory.embedding import embed
from robocog.server.memory.episodic import EpisodeInput, EpisodicMemory

RECORDS = 10_000
SEARCHES = 200
WRITES = 100
EMBED_SINGLE = 100
EMBED_BATCHES = 8
BATCH = 32

_VERBS = ["put", "place", "move", "bring", "carry", "take", "stack", "store", "drop", "set"]
_ADJECTIVES = ["red", "blue", "green", "small", "large", "dirty", "clean", "empty", "full", "wooden", "metal", ""]
_OBJECTS = [
    "apple", "banana", "mug", "cup", "plate", "bowl", "sponge", "book", "remote control", "bottle",
    "can of soda", "spoon", "fork", "knife", "towel", "box", "block", "toy car", "pen", "phone",
]  # fmt: skip
_PLACES = [
    "on the kitchen table", "in the fridge", "into the sink", "on the top shelf", "in the drawer",
    "on the sofa", "in the trash bin", "on the counter", "in the cabinet", "next to the lamp",
    "on the bedside table", "in the basket", "on the desk", "under the chair", "in the microwave",
]  # fmt: skip
_OTHER = [
    "open the {p} door", "close the {p} door", "wipe the {p} with the sponge", "turn on the lamp {q}",
    "find the {o} and tell me where it is", "put away all the items {q}", "count the {o}s {q}",
    "clear everything {q}", "sort the objects by colour {q}", "check whether the {o} is {q}",
]  # fmt: skip


def _task(rng: random.Random) -> str:
    if rng.random() < 0.75:
        adjective = rng.choice(_ADJECTIVES)
        obj = f"{adjective} {rng.choice(_OBJECTS)}".strip()
        text = f"{rng.choice(_VERBS)} the {obj} {rng.choice(_PLACES)}"
        if rng.random() < 0.3:
            text += f", then {rng.choice(_VERBS)} the {rng.choice(_OBJECTS)} {rng.choice(_PLACES)}"
        return text
    template = rng.choice(_OTHER)
    return template.format(
        p=rng.choice(["fridge", "cabinet", "oven", "microwave", "kitchen table"]),
        o=rng.choice(_OBJECTS),
        q=rng.choice(_PLACES),
    )


def _entry(rng: random.Random, i: int) -> EpisodeInput:
    ok = rng.random() < 0.6
    return {
        "task_description": _task(rng),
        "believed_status": "success" if ok else "failure",
        "summary": f"episode {i}: {'completed after checking each object' if ok else 'gripper missed the object'}",
        "model": rng.choice(["gpt-4o", "claude-sonnet", "qwen2.5-7b"]),
        "tool_calls": rng.randint(3, 40),
        "duration_s": round(rng.uniform(5, 300), 2),
        "episode": f"ep-{i:05d}",
    }


def _ms_percentiles(samples: list[float]) -> tuple[float, float]:
    ordered = sorted(samples)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return round(statistics.median(ordered) * 1000, 3), round(p95 * 1000, 3)


def _time(fn: Callable[[], object]) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def run() -> dict[str, float]:
    """Measure embedding and memory latencies; return a flat dict of numbers."""
    rng = random.Random(0)
    # Other processes skew latencies: record the machine's size and load alongside the numbers.
    results: dict[str, float] = {"host.cpus": float(os.cpu_count() or 0)}
    if hasattr(os, "getloadavg"):
        results["host.loadavg_1m_start"] = round(os.getloadavg()[0], 2)

    sentences = [_task(rng) for _ in range(EMBED_SINGLE)]
    embed(sentences[:4])  # warm up (model load, integrity check)
    single = [_time(partial(embed, [s])) for s in sentences]
    results["embed.single_p50_ms"], results["embed.single_p95_ms"] = _ms_percentiles(single)
    batches = [[_task(rng) for _ in range(BATCH)] for _ in range(EMBED_BATCHES)]
    batch_times = [_time(partial(embed, b)) for b in batches]
    results["embed.batch32_per_sentence_ms"] = round(statistics.median(batch_times) / BATCH * 1000, 3)

    with tempfile.TemporaryDirectory() as tmp, EpisodicMemory(Path(tmp), namespace="bench") as memory:
        entries = [_entry(rng, i) for i in range(RECORDS)]
        fill = _time(lambda: memory.add_many(entries))
        results["memory.records"] = memory.count()
        results["memory.fill_s"] = round(fill, 2)
        results["memory.fill_per_record_ms"] = round(fill / RECORDS * 1000, 3)

        queries = [_task(rng) for _ in range(SEARCHES)]
        memory.search(queries[0])  # warm up
        searches = [_time(partial(memory.search, q, k=3)) for q in queries]
        results["memory.search_p50_ms"], results["memory.search_p95_ms"] = _ms_percentiles(searches)

        writes = [_entry(rng, RECORDS + i) for i in range(WRITES)]
        adds = [_time(partial(memory.add, **e)) for e in writes]
        results["memory.add_p50_ms"], results["memory.add_p95_ms"] = _ms_percentiles(adds)
    results |= _units_in_child()
    if hasattr(os, "getloadavg"):
        results["host.loadavg_1m_end"] = round(os.getloadavg()[0], 2)
    return results


#: Units per round, and rounds, of `units`.
UNITS, UNIT_ROUNDS = 24, 5


def units() -> dict[str, float]:
    """A unit's memory work, CPU per unit (every thread of the process: Chroma's own included) and wall
    time, with the client kept (`keep` of 8) and with one per namespace (`keep` of 1: stopped as each
    closes), on disk (this machine's temporary directory); and kept, on the RAM file system a study's
    servers keep their memory in (`scratch`; where the machine has one with room)."""
    from robocog.agent.harness.scratch import scratch_root
    from robocog.server.memory import chroma

    ram = scratch_root()
    # (name, Chroma clients kept, on the RAM file system)
    ways = [("kept", chroma.KEEP_NAMESPACES, False), ("client_per_namespace", 1, False)]
    ways += [("scratch", chroma.KEEP_NAMESPACES, True)] if ram is not None else []
    spent = dict.fromkeys((way for way, _, _ in ways), 0.0)
    walls = dict.fromkeys(spent, 0.0)
    with tempfile.TemporaryDirectory() as on_disk, tempfile.TemporaryDirectory(dir=ram or on_disk) as in_ram:
        for i in range(UNIT_ROUNDS + 1):
            for way, keep, ram_backed in ways:
                chroma.EMBEDDED.stop_idle()
                chroma.EMBEDDED.keep = keep
                start, wall = time.process_time(), time.perf_counter()
                for unit in range(UNITS):
                    data = Path(in_ram if ram_backed else on_disk) / way
                    with EpisodicMemory(data, namespace=f"unit-{i}-{unit}") as memory:
                        memory.count()
                        memory.search("Put away all the items into the shelf.")
                        record = memory.add("Put away all the items.", "success", "Done.", episode=f"{i}-{unit}")
                        memory.set_verified(record.id, "success")
                        memory.count()
                        memory.drop()
                if i > 0:  # the first round warms up (the embedding model, Chroma's first statements)
                    spent[way] += time.process_time() - start
                    walls[way] += time.perf_counter() - wall
    per_unit = 1000 / (UNITS * UNIT_ROUNDS)
    return {f"memory.unit.{way}_cpu_ms": round(cpu * per_unit, 2) for way, cpu in spent.items()} | {
        f"memory.unit.{way}_wall_ms": round(wall * per_unit, 2) for way, wall in walls.items()
    }


def _units_in_child() -> dict[str, float]:
    done = subprocess.run(
        [sys.executable, __file__, "--units"], capture_output=True, text=True, check=True, timeout=900
    )
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


if __name__ == "__main__":
    print(
        json.dumps(units() if sys.argv[1:] == ["--units"] else run(), indent=2 if sys.argv[1:] != ["--units"] else None)
    )
