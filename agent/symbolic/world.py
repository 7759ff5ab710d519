"""The names-only world the suite generator plans over: a scene's names, where the objects rest, the
robot's actions. No physics: the server's world is never imported here."""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass

from robocog.assets import ASSETS_DIR
from robocog.shared.scene import Scene
from robocog.shared.tasks import Spot

__all__ = ["Action", "SceneNames", "Spot", "Where"]

Where = dict[str, Spot | None]  # object -> its place position; None: in the robot's hand
#: ("move_to", location) | ("grab", object) | ("place", "location/position") | ("open" / "close", container)
Action = tuple[str, str]


#: The physics survey of the shipped scenes (`python -m robocog.server.world.reach`).
REACH_FILE = ASSETS_DIR / "scenes" / "reach.json"


@functools.cache
def unreachable(scene: str) -> frozenset[Spot]:
    """The place positions of the shipped scene `scene` the arm misses with some object (none for a
    scene the survey does not know)."""
    survey = json.loads(REACH_FILE.read_text(encoding="utf-8")) if REACH_FILE.exists() else {}
    return frozenset((loc, pos) for loc, pos in survey.get(scene, []))


@dataclass(frozen=True)
class SceneNames:
    """What the generator needs of a scene: its names (objects, place positions, furniture), no physics."""

    scene: Scene

    @property
    def name(self) -> str:
        """The scene's name."""
        return self.scene.name

    @property
    def spots(self) -> list[Spot]:
        """Every place position the arm reaches with every object of the scene, in scene order: a
        position the physics survey found out of reach for some object (`unreachable`) is never a
        start, a target nor a parking place of a generated task."""
        out_of_reach = unreachable(self.scene.name)
        return [(p.location, p.name) for p in self.scene.place_positions if (p.location, p.name) not in out_of_reach]

    @property
    def inside_spots(self) -> list[Spot]:
        """The place positions inside furniture that opens (a container's interior), in scene order."""
        containers = {c.name for c in self.scene.containers}
        return [(p.location, p.name) for p in self.scene.place_positions if p.support in containers]

    @property
    def open_spots(self) -> list[Spot]:
        """The place positions in the open (not inside a container), in scene order: where a random
        start puts objects, so only a family about containers puts any inside one."""
        inside = set(self.inside_spots)
        return [s for s in self.spots if s not in inside]

    @property
    def graspable(self) -> list[str]:
        """The objects the robot can grasp, in scene order."""
        return [o.name for o in self.scene.objects if o.graspable]

    @property
    def ungraspable(self) -> list[str]:
        """The objects it cannot grasp (fixtures such as a TV), in scene order."""
        return [o.name for o in self.scene.objects if not o.graspable]

    def room_of(self, location: str) -> str:
        """The room whose floor holds `location`'s point (the first in scene order; "" when none)."""
        point = self.scene.location(location)
        for room in self.scene.rooms:
            if room.x[0] <= point.x <= room.x[1] and room.y[0] <= point.y <= room.y[1]:
                return room.name
        return ""

    @property
    def containers(self) -> dict[str, str]:
        """Each container (furniture that opens), by name, and the location the robot opens it from."""
        return {c.name: c.location for c in self.scene.containers}

    @property
    def inside(self) -> dict[Spot, str]:
        """Each place position inside a container (its support names the container) and that container:
        the robot reaches it only while the container is open."""
        names = self.containers
        out: dict[Spot, str] = {}
        for p in self.scene.place_positions:
            box = p.support.split("/")[0]
            if box in names:
                out[(p.location, p.name)] = box
        return out

    def spots_at(self, location: str) -> list[Spot]:
        """The place positions of `location`, in scene order."""
        return [s for s in self.spots if s[0] == location]

    def furniture(self) -> list[tuple[str, list[Spot]]]:
        """Each piece of furniture with place positions: its name in a prompt (the location of its
        positions when they share one, else its own name) and its positions, in scene order."""
        out: list[tuple[str, list[Spot]]] = []
        for f in self.scene.furniture:
            spots = [(p.location, p.name) for p in self.scene.place_positions if p.support.split("/")[0] == f.name]
            if spots:
                locations = {loc for loc, _ in spots}
                name = spots[0][0] if len(locations) == 1 else f.name.replace("_", " ").title()
                out.append((name, spots))
        return out
