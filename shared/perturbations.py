"""Things that go wrong, as data: seeded perturbations a scene or an episode declares.

A `Perturbation` is one event the world makes happen during an episode, in physics:

- `slip`: the held object slips out of the hand while the robot drives with it (during the
  `on_drive`-th drive with an object in hand, as it arrives at a seeded location of the way: one it
  passes or its destination), falls to the floor beside that location, within the arm's reach from
  there, and comes to rest where physics puts it; the robot drives on;
- `move_object`: someone moves `object` to the place position `to` (`[location, position]`; default:
  a free floor position drawn from the episode's seed) while the robot is not at the object's
  location and does not hold it;
- `close_container`: someone closes `container` while the robot is not at its location;
- `block_edge`: the corridor between the two locations of `edge` is blocked for `duration` tool
  calls; `move_to` through it stops at the last location before the block and says why.

What robocog-v2.1 uses is triggered by the world's state, not by a count of calls (`when`):

- `when: approach` (move_object): someone moves the object as the robot sets off on the first drive
  that would take it to the object (its route ends in the object's room, or passes where it lies),
  while the robot neither holds it nor stands by it: whatever order an agent calls its tools in, the
  object is gone before it can be grasped;
- `when: route` (block_edge): the corridor is blocked as the robot sets off on the first drive whose
  route needs it (then for `duration` tool calls): the drive stops before it;
- `when: leave` (close_container): someone closes the container behind the robot on the first drive
  that takes the robot away from it after the robot opened it (as that drive ends): whatever order an
  agent calls its tools in, a container it must open with a free hand, and leave to fetch what goes
  in, is shut again when it comes back.

Without `when` (robocog-v1 and robocog-v2), all but `slip` are due at the `at_call`-th robot tool call
since the reset (the episode's own count
for the episode a reset begins; a later episode in the same world, T2 after T1, goes on counting),
and wait for the robot to be elsewhere when they need it to be; `duration` counts the same calls.
`announce`: the result of the call during which it happened gets a sentence "Something changed:
..."; otherwise it is silent. Each one that happens
is a `PerturbationEvent` (kind, what, the call it happened at), which the server hands to the client
with the tool result (`_meta`, `PERTURBATION_META_KEY`) and the client writes into its trace.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field, model_validator

from robocog.shared.config_files import STRICT_CONFIG
from robocog.shared.limits import NAME_CHARS

#: Where a tool result's `_meta` carries the perturbations that happened during the call.
PERTURBATION_META_KEY = "robocog/perturbations"
#: The most perturbations one scene or episode may declare.
MAX_PERTURBATIONS = 16

PerturbationKind = Literal["slip", "move_object", "close_container", "block_edge"]
#: What sets a perturbation off in the world (None: the `at_call`-th call).
Trigger = Literal["approach", "route", "leave"]
#: The kind each trigger applies to.
TRIGGER_KINDS: dict[str, str] = {"approach": "move_object", "route": "block_edge", "leave": "close_container"}

#: A name inside a pair (a location, a position).
Name = Annotated[str, Field(min_length=1, max_length=NAME_CHARS)]


class Perturbation(BaseModel):
    """One thing that goes wrong during an episode (see the module's docstring)."""

    model_config = STRICT_CONFIG

    kind: PerturbationKind = Field(description="slip | move_object | close_container | block_edge")
    at_call: int = Field(
        default=1, ge=1, le=1000, description="due at this robot tool call since the reset (not for slip)"
    )
    when: Trigger | None = Field(
        default=None,
        description="approach (move_object): as the robot sets off towards the object; route (block_edge): as "
        "the robot sets off on a drive that needs the corridor; leave (close_container): behind the robot, on "
        "its first drive away from the container after it opened it; absent: at `at_call`",
    )
    on_drive: int = Field(default=1, ge=1, le=100, description="slip: during this drive with an object in hand")
    object: str | None = Field(default=None, min_length=1, max_length=NAME_CHARS, description="move_object: which")
    to: tuple[Name, Name] | None = Field(
        default=None, description="move_object: [location, position] it goes to (default: a seeded free floor spot)"
    )
    container: str | None = Field(
        default=None, min_length=1, max_length=NAME_CHARS, description="close_container: which"
    )
    edge: tuple[Name, Name] | None = Field(default=None, description="block_edge: the two locations of the corridor")
    duration: int = Field(default=3, ge=1, le=1000, description="block_edge: for how many tool calls")
    announce: bool = Field(default=False, description="the next tool result says that something changed")

    @model_validator(mode="after")
    def _needs(self) -> Perturbation:
        needed = {"move_object": "object", "close_container": "container", "block_edge": "edge"}.get(self.kind)
        if needed is not None and getattr(self, needed) is None:
            raise ValueError(f"a {self.kind} perturbation needs `{needed}`")
        if self.when is not None and TRIGGER_KINDS[self.when] != self.kind:
            raise ValueError(f"when: {self.when!r} sets off a {TRIGGER_KINDS[self.when]}, not a {self.kind}")
        return self


class PerturbationEvent(BaseModel):
    """A perturbation that happened: what, at which robot tool call of the episode, announced or not."""

    kind: PerturbationKind
    call: int = Field(description="the robot tool call of the episode during which it happened")
    description: str = Field(description="what happened, in a sentence")
    announced: bool = Field(description="the tool result said so")
    object: str | None = None
    container: str | None = None
    edge: tuple[str, str] | None = None
    xyz: tuple[float, float, float] | None = Field(default=None, description="where the object came to rest")
    ended: bool = Field(default=False, description="block_edge: the block lifted (an event of its own)")
