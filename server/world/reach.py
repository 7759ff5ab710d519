"""Which place positions the arm cannot reach with every object of a scene: a survey in physics, for the
suite generator (which reads names only and must not pose a task the arm cannot do).

Whether the arm reaches a place position depends on the object in the hand: a tall one is held
higher above the surface, so the top layer of a shelf that a cube fits onto may be beyond the arm
with a bottle. For each graspable object, the survey picks it up twice, where the scene starts it
and from a floor position (a real `pick`, which leaves it in the carry pose; the grip differs a
little), and, standing at each location, asks the arm's inverse kinematics for the hand pose
`put_down` would need over each of that location's open place positions (not those inside
containers: the drawer's tray slides out when open). A position is unreachable when some object
misses it by more than the grasp threshold less `MARGIN_M` (a carried object sways a little in the
hand while the robot drives, so the survey keeps a margin).

    python -m robocog.server.world.reach > assets/scenes/reach.json    # every shipped scene

The file maps a scene's name to its unreachable positions, `[location, position]` pairs; the suite
generator leaves those out of a suite whose manifest asks it to (`exclude_unreachable`), and a test
surveys a sample of scenes again and compares.
"""

from __future__ import annotations

import json
import math
import sys

from robocog.server.world import actions
from robocog.server.world.cstdio import stdout_to_stderr
from robocog.server.world.world import World
from robocog.shared.scene_files import generated_scene_names, scene_names, scene_path

#: The survey's margin under the grasp threshold, metres.
MARGIN_M = 0.04
#: A grip is trusted when the object's origin is this close to the hand (else the pick knocked it about).
HELD_WITHIN_M = 0.3


def unreachable_positions(world: World) -> list[tuple[str, str]]:
    """The open place positions of `world`'s scene that the arm misses with some graspable object, in
    scene order (the world is reset and left in its start state)."""
    sim = world.sim
    c, robot, spec = sim.client, sim.robot, sim.robot_spec
    missed: set[tuple[str, str]] = set()
    for obj_spec in [o for o in sim.scene.objects if o.graspable]:
        obj = sim.objects[obj_spec.name]
        for picked in (_picked_where_it_starts, _picked_from_the_floor):  # two grips: the hand holds it
            if not picked(world, obj_spec.name):  # a little differently each time
                continue
            hx, hy, hz = robot.end_effector()
            (ox, oy, oz), _ = c.getBasePositionAndOrientation(obj.body)
            if math.dist((hx, hy, hz), (ox, oy, oz)) > HELD_WITHIN_M:  # a grip that knocked it about
                continue
            for (location, name), pos in sim.positions.items():
                if pos.container is not None or (location, name) in missed:
                    continue
                robot.set_base(*sim.map.points[location], robot.yaw)
                cx, cy = sim.center(pos)
                hand = (cx + hx - ox, cy + hy - oy, pos.surface_z + obj.bottom + spec.place_clearance + hz - oz)
                if robot.solve_ik(hand)[1] > spec.grasp_threshold - MARGIN_M:
                    missed.add((location, name))
    world.reset(seed=0)
    return [key for key in sim.positions if key in missed]


def _picked_where_it_starts(world: World, name: str) -> bool:
    """Reset and pick the object up where the scene starts it; whether that worked (not from a
    closed container, nor from a position out of reach)."""
    world.reset(seed=0)
    start = world.placement(name).location
    if start is None:
        return False
    world.sim.robot.set_base(*world.sim.map.points[start], world.sim.robot.yaw)
    return actions.pick(world.sim, name).ok


def _picked_from_the_floor(world: World, name: str) -> bool:
    """Reset, put the object on a floor position (wherever the scene starts it: a closed drawer, a
    high shelf) and pick it up from there; whether that worked."""
    sim = world.sim
    for (location, _), pos in sim.positions.items():
        if pos.spec.support != "floor":
            continue
        world.reset(seed=0)
        sim.put_on(sim.objects[name], pos, 0.0)
        sim.settle()
        sim.robot.set_base(*sim.map.points[location], sim.robot.yaw)
        if actions.pick(sim, name).ok:
            return True
    return False


def survey(names: list[str]) -> dict[str, list[list[str]]]:
    """Each named scene's unreachable positions."""
    out: dict[str, list[list[str]]] = {}
    for name in names:
        world = World(scene_path(name), seed=0)
        try:
            out[name] = [list(p) for p in unreachable_positions(world)]
        finally:
            world.close()
    return out


def main() -> int:
    names = sys.argv[1:] or scene_names() + generated_scene_names()
    with stdout_to_stderr():
        found = survey(names)
    print(json.dumps(found, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
