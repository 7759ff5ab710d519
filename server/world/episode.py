"""Episode initialisation: a fresh simulation of the scene, in its static start or seeded at random.

Randomizations (`options={"randomize": True}`): every graspable object starts on a distinct
place position, drawn with a random yaw from the world's one generator, in scene order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from pybullet_utils.bullet_client import BulletClient

from robocog.server.world.builder import build
from robocog.server.world.sim import Sim
from robocog.shared.errors import WorldError
from robocog.shared.robot_spec import RobotSpec
from robocog.shared.scene import Scene

#: The options `reset` understands, with what each must be.
OPTIONS: dict[str, type] = {"randomize": bool}


def check_options(options: Mapping[str, Any] | None) -> None:
    """Raise WorldError for an option `reset` does not know or a value of the wrong type."""
    options = options or {}
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise WorldError(f"unknown reset option(s): {', '.join(unknown)}; known: {', '.join(OPTIONS)}")
    for key, value in options.items():
        if not isinstance(value, OPTIONS[key]):
            raise WorldError(f"reset option {key!r} must be a {OPTIONS[key].__name__}, not {value!r}")


def reset(
    client: BulletClient,
    scene: Scene,
    robot_spec: RobotSpec,
    rng: np.random.Generator,
    options: Mapping[str, Any] | None = None,
) -> Sim:
    """The scene rebuilt from nothing in `client` (so no sleeping state or contact cache of a past
    episode carries over), objects settled, the step count at zero."""
    check_options(options)
    client.resetSimulation()
    sim = build(client, scene, robot_spec)
    if (options or {}).get("randomize", False):
        randomize(sim, rng)
        sim.settle()
    sim.steps = 0
    return sim


def randomize(sim: Sim, rng: np.random.Generator) -> None:
    """Every graspable object onto its own random place position, with a random yaw."""
    graspable = [o for o in sim.objects.values() if o.spec.graspable]
    keys = list(sim.positions)
    if len(keys) < len(graspable):
        raise WorldError(f"cannot randomize: {len(graspable)} objects but {len(keys)} place positions")
    chosen = rng.choice(len(keys), size=len(graspable), replace=False)
    for obj, index in zip(graspable, chosen, strict=True):
        sim.put_on(obj, sim.positions[keys[int(index)]], float(rng.uniform(-math.pi, math.pi)))
