"""Results of the robot's actions and the world's ground truth, as pydantic models.

The world returns these from its plain Python API; the MCP server publishes them as structured
tool output (their JSON schemas become the tools' `outputSchema`); the client reads them back.
Every failure is a result with `status: "failure"`, an `error` code and a message a model can act on.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field, PrivateAttr

Status = Literal["success", "failure"]

ErrorCode = Literal[
    "unknown_location",
    "unknown_object",
    "unknown_position",
    "no_path",
    "not_at_location",
    "out_of_reach",
    "already_holding",
    "nothing_held",
    "position_occupied",
    "not_graspable",
    "place_failed",
]


#: A grab's or place's `container`: the error is `out_of_reach` because this furniture is closed.
CONTAINER_IN_THE_WAY = "on out_of_reach, the closed furniture in the way: open(container) first (absent otherwise)"


class ActionResult(BaseModel):
    """What every robot action returns."""

    status: Status = Field(description="'success' if the action did what was asked, else 'failure'")
    message: str = Field(description="what happened, and on failure what to do about it")
    error: ErrorCode | None = Field(default=None, description="machine-readable reason of a failure")
    suggestions: list[str] = Field(default=[], description="valid names close to a misspelt one")


class PositionView(BaseModel):
    """A place position as the robot perceives it."""

    name: str = Field(description="the position's name, to pass to place()")
    occupied_by: str | None = Field(default=None, description="the object resting there, if any")


class LocationView(BaseModel):
    """A semantic location as the robot perceives it."""

    name: str
    neighbours: list[str] = Field(description="locations reachable directly from here")
    objects: list[str] = Field(description="objects at this location (on its positions or nearby)")
    place_positions: list[PositionView] = Field(description="where objects can be placed here")


#: What look_around reveals: the robot's own location, the room it is in, or the whole house.
Observe = Literal["location", "room", "house"]
#: A container is "closed" (nothing inside can be seen or reached) or "open" (part or all the way).
OpenState = Literal["open", "closed"]


def _absent(value: object) -> bool:
    """Left out of a result when it says nothing (None, or an empty list): worlds without containers, and
    look_around under full observation, read exactly as they did before these fields existed."""
    return value is None or value == []


class FurnitureView(BaseModel):
    """Furniture that opens (a drawer, a cabinet, a fridge) as the robot perceives it."""

    name: str = Field(description="the furniture's name, to pass to open() and close()")
    kind: Literal["drawer", "cabinet", "fridge"]
    location: str = Field(description="the location the robot stands at to open it")
    state: OpenState = Field(description="'closed': what is inside can be neither seen nor reached")


class LookAroundResult(ActionResult):
    """The robot's view of the world."""

    location: str = Field(description="where the robot is")
    holding: str | None = Field(default=None, description="the object in the robot's hand, if any")
    locations: list[LocationView] = Field(default=[], description="every location with its objects")
    furniture: list[FurnitureView] = Field(
        default=[], description="furniture that opens, at the locations seen", exclude_if=_absent
    )
    observed: Observe | None = Field(
        default=None,
        description="under partial observation, what was seen: the robot's 'location' or its 'room', and "
        "`locations` lists only those (absent: the whole house)",
        exclude_if=_absent,
    )


class MoveResult(ActionResult):
    """The outcome of move_to."""

    location: str = Field(description="where the robot is after the action")
    path: list[str] = Field(default=[], description="the locations passed through, start and goal included")
    distance_m: float = Field(default=0.0, description="distance driven, metres")


class GrabResult(ActionResult):
    """The outcome of grab."""

    object: str | None = Field(default=None, description="the object the action was about")
    holding: str | None = Field(default=None, description="the object in the robot's hand afterwards")
    container: str | None = Field(default=None, description=CONTAINER_IN_THE_WAY, exclude_if=_absent)


FurnitureError = Literal[
    "unknown_furniture",
    "not_openable",
    "not_at_location",
    "already_holding",
    "out_of_reach",
    "blocked",
]


class OpenCloseResult(BaseModel):
    """The outcome of open or close: what physics did to the furniture's joint (an action's result, with
    error codes of its own)."""

    status: Status = Field(description="'success' if the action did what was asked, else 'failure'")
    message: str = Field(description="what happened, and on failure what to do about it")
    error: FurnitureError | None = Field(default=None, description="machine-readable reason of a failure")
    suggestions: list[str] = Field(default=[], description="valid names close to a misspelt one")
    furniture: str = Field(description="the furniture the action was about")
    outcome: Literal["opened", "closed", "already_open", "already_closed", "blocked"] | None = Field(
        default=None, description="what happened to the drawer or door, when the robot got to its handle"
    )
    state: OpenState | None = Field(default=None, description="the furniture's state afterwards")
    opening: float | None = Field(default=None, description="how far open afterwards, 0 (closed) to 1 (fully)")
    steps: int = Field(default=0, description="physics steps the action took")


class PlaceResult(ActionResult):
    """The outcome of place."""

    object: str | None = Field(default=None, description="the object placed (or that was to be placed)")
    location: str | None = None
    position: str | None = None
    holding: str | None = Field(default=None, description="the object in the robot's hand afterwards")
    container: str | None = Field(default=None, description=CONTAINER_IN_THE_WAY, exclude_if=_absent)


# --- the camera ------------------------------------------------------------------------------------


class ImageInfo(BaseModel):
    """What a picture attached to a result is (its pixels are an MCP image content block, not JSON)."""

    mime_type: Literal["image/png"] = "image/png"
    width: int = Field(description="pixels across")
    height: int = Field(description="pixels down")


class WithImage(BaseModel):
    """A result that carries a picture. The bytes are not a field: the server sends them as an MCP
    image content block beside the JSON (structured content stays small); `image` describes them."""

    image: ImageInfo | None = Field(default=None, description="the picture sent as an image content block, if any")
    _image_bytes: bytes | None = PrivateAttr(default=None)

    @property
    def image_bytes(self) -> bytes | None:
        """The encoded picture (see `image.mime_type`), when one is attached."""
        return self._image_bytes

    def attach_image(
        self, data: bytes, *, width: int, height: int, mime_type: Literal["image/png"] = "image/png"
    ) -> None:
        """Attach an encoded picture of `width` x `height` pixels."""
        self._image_bytes = data
        self.image = ImageInfo(mime_type=mime_type, width=width, height=height)


class SeenObject(BaseModel):
    """An object in the camera's view, from ground truth."""

    name: str
    where: str = Field(description="where it is, e.g. 'on Kitchen Table middle' or 'in the robot's hand'")
    distance_m: float = Field(description="from the camera, metres")
    bearing_deg: float = Field(description="angle from the middle of the view, degrees, positive to the left")
    side: Literal["ahead", "to the left", "to the right"] = Field(description="where in the view")


class Caption(BaseModel):
    """What the camera's view shows, from ground truth (not from the pixels)."""

    text: str = Field(description="one line saying what is visible")
    objects: list[SeenObject] = Field(default=[], description="objects in view, nearest first")
    furniture: list[str] = Field(default=[], description="furniture in view")
    locations: list[str] = Field(default=[], description="locations of the map whose spot on the floor is in view")


class LookResult(WithImage, ActionResult):
    """The outcome of look: the picture is an image content block; this says where the camera looked."""

    location: str = Field(description="where the robot is")
    direction: str = Field(description="where the camera looked: 'ahead', 'left', ..., or 'toward NAME'")
    heading_deg: float = Field(description="the camera's heading on the map, degrees (0 is +x, counter-clockwise)")
    tilt_deg: float = Field(description="the camera's tilt, degrees (negative is down)")
    caption: Caption | None = Field(default=None, description="what is visible, only when asked for")


# --- ground truth -------------------------------------------------------------------------------


class ObjectPlacement(BaseModel):
    """Where an object is, derived from its pose and contacts in the physics state."""

    object: str
    state: Literal["on_position", "held", "loose"] = Field(
        description="resting on a place position, held by the robot, or anywhere else"
    )
    location: str | None = Field(default=None, description="the location it is at or nearest to")
    position: str | None = Field(default=None, description="the place position it rests on")
    xyz: tuple[float, float, float]
    resting: bool = Field(description="at rest and supported (not moving, not held)")
    room: str | None = None
    inside: str | None = Field(
        default=None,
        description="the container (drawer, cabinet, fridge) whose interior holds it, open or closed",
        exclude_if=_absent,
    )


class PositionState(BaseModel):
    """A place position and what rests on it."""

    location: str
    position: str
    occupied_by: str | None = None


class RobotState(BaseModel):
    """The robot's pose and hand."""

    location: str
    xyz: tuple[float, float, float]
    yaw: float
    holding: str | None = None


class FurnitureState(FurnitureView):
    """Furniture that opens, from the physics state: its joint, and what its interior holds."""

    opening: float = Field(description="how far open, 0 (closed) to 1 (fully open)")
    contents: list[str] = Field(default=[], description="the objects inside, seen or not")


class WorldState(BaseModel):
    """The ground truth of the whole world."""

    robot: RobotState
    objects: list[ObjectPlacement]
    positions: list[PositionState]
    sim_time_s: float
    steps: int
    furniture: list[FurnitureState] = Field(
        default=[], description="furniture that opens (absent when there is none)", exclude_if=_absent
    )


class ObjectVerdict(BaseModel):
    """Whether one object meets a task's success condition, and why."""

    object: str
    ok: bool
    reason: str


class TaskVerdict(BaseModel):
    """The ground-truth verdict of a task: success only if every object's condition holds."""

    task_id: str
    success: bool
    reason: str = Field(description="one line summing up the verdict")
    objects: list[ObjectVerdict] = []


class RobotView(WithImage):
    """What the robot app (`ui://robocog/robot`) draws: the map's geometry, the ground truth, and the
    verdict of the episode's task where the server knows the task; the camera's picture when asked."""

    status: Status = "success"
    scene: dict[str, Any] | None = Field(
        default=None, description="the map's geometry (rooms, walls, furniture, positions, locations, edges)"
    )
    world: WorldState = Field(description="the ground truth: the robot, each object, each position, the furniture")
    task_id: str | None = Field(default=None, description="the episode's task, where the server knows it")
    verdict: TaskVerdict | None = Field(default=None, description="the task's verdict for the world as it is now")
    episode: int = Field(description="the number of the current episode")
    tool_calls: int = Field(description="robot tool calls made in the episode")


# --- working and episodic memory, episodes --------------------------------------------------------


class ScratchpadResult(BaseModel):
    """The outcome of add_to_scratchpad."""

    status: Status
    message: str
    entries: int = Field(description="entries on the scratchpad now")
    dropped: int = Field(default=0, description="oldest entries dropped to stay within the scratchpad's bounds")


class ScratchpadView(BaseModel):
    """The scratchpad's content."""

    status: Status = "success"
    message: str
    content: str = Field(description="all entries, oldest first, separated by blank lines")
    entries: int


class Experience(BaseModel):
    """A past episode as search_memory shows it to the agent."""

    task_description: str = Field(description="the task as it was given")
    status: Status = Field(description="how the episode ended (the agent's belief, or the verified outcome)")
    status_source: Literal["believed", "verified"] = Field(
        description="'believed': the agent's own report; 'verified': checked against the world"
    )
    summary: str = Field(description="what was done and learned")
    when: str = Field(description="when it was recorded (ISO-8601, UTC)")
    distance: float = Field(description="cosine distance to the query, smaller is closer")


class MemorySearchResult(BaseModel):
    """The outcome of search_memory."""

    status: Status
    message: str
    results: list[Experience] = []


class EndTaskResult(BaseModel):
    """The outcome of end_task."""

    status: Status
    message: str
    record_id: str | None = Field(default=None, description="the episodic-memory record written")
    episode: int = Field(description="the number of the episode that ended")
    episode_id: str | None = Field(default=None, description="the id of the episode, stored with its record")
    tool_calls: int = Field(description="robot tool calls made in the episode")
