"""The generated houses (`robocog.agent.housegen`): build + reset of each of the fifty shipped houses
(p50, p95, max), the oracle's tour of every house (every container opened, one object carried over every
free place position with the world's own actions, ground truth reporting it at rest on each), and the
memory one more world of a generated house costs, against the paper's household."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from robocog.agent.housegen import SHIPPED_HOUSES, house_name
from robocog.server.world.world import World

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.house_tour
from tests.house_tour import start_problems, tour

#: Worlds built in one process to measure the memory each more one costs.
WORLDS = 8

_RSS = """
import json, sys
from robocog.server.world.world import World
def rss():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
worlds, sizes = [], []
for _ in range(int(sys.argv[2])):
    worlds.append(World(sys.argv[1]))
    worlds[-1].reset()
    sizes.append(rss())
print(json.dumps(sizes))
"""


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def _mb_per_world(scene: str) -> float:
    """RSS growth per world after the first, from a process of its own."""
    out = subprocess.run(
        [sys.executable, "-c", _RSS, scene, str(WORLDS)], capture_output=True, text=True, check=True
    ).stdout
    sizes = json.loads(out.strip().splitlines()[-1])
    return round((sizes[-1] - sizes[0]) / (len(sizes) - 1), 1)


def run() -> dict[str, float | int | bool]:
    builds: list[float] = []
    positions = reached = sound = 0
    problems: list[str] = []
    World("household").close()  # the first world of a process pays for imports and pybullet_data's caches
    for seed in range(SHIPPED_HOUSES):
        start = time.perf_counter()
        world = World(house_name(seed))
        world.reset()
        builds.append(time.perf_counter() - start)
        wrong = start_problems(world)
        got, free, failed = tour(world)
        world.close()
        positions += free
        reached += got
        sound += not (wrong or failed)
        problems += [f"{house_name(seed)}: {p}" for p in wrong + failed]
    for line in problems:
        print(f"bench houses: {line}", file=sys.stderr)
    return {
        "houses.count": SHIPPED_HOUSES,
        "houses.build_reset_p50_s": round(statistics.median(builds), 3),
        "houses.build_reset_p95_s": round(_percentile(builds, 0.95), 3),
        "houses.build_reset_max_s": round(max(builds), 3),
        "houses.oracle_positions": positions,
        "houses.oracle_reached": reached,
        "houses.oracle_sound_houses": sound,
        "houses.mb_per_world_household": _mb_per_world("household"),
        "houses.mb_per_world_house": _mb_per_world(house_name(LARGEST)),
        "houses.load_average": round(os.getloadavg()[0], 2),  # the machine is shared: how busy it was
    }


#: One of the largest shipped houses (house-048: five rooms, 20 pieces of furniture, 36 place positions), for memory.
LARGEST = 48
