"""The robot's camera: the `look` tool through MCP, the rendering as a plain function of the world, and
the client passing pictures to vision models (and a one-line note to text-only ones) over real HTTP.
"""

from __future__ import annotations

import base64
import io
import json
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcp import Client
from mcp_types import CallToolResult, ImageContent, TextContent
from PIL import Image

from robocog.agent.client.loop import run_episode
from robocog.agent.client.model import IMAGE_OMITTED
from robocog.agent.client.settings import AgentSettings
from robocog.agent.client.trace_sinks import Trace
from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.server.robots.session import RobotSession
from robocog.server.tools import look
from robocog.server.world import camera
from robocog.server.world.world import World
from robocog.shared.trace import ToolResult, read_trace
from tests.fake_llm import FakeLLM, Turn

pytestmark = pytest.mark.anyio

CUBE_RED = (0.85, 0.15, 0.15)


@pytest.fixture
async def robot(tmp_path: Path) -> AsyncIterator[Client]:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"))
    async with Client(server, raise_exceptions=True) as client:
        yield client


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    with World() as w:
        yield w


def picture(result: CallToolResult) -> np.ndarray:
    """The image block of a result, decoded (by Pillow, not by our encoder) to height x width x 3."""
    images = [b for b in result.content if isinstance(b, ImageContent)]
    assert len(images) == 1 and images[0].mime_type == "image/png"
    decoded = Image.open(io.BytesIO(base64.b64decode(images[0].data)))
    assert decoded.mode == "RGB"
    return np.asarray(decoded)


def red_pixels(rgb: np.ndarray) -> int:
    """Pixels of the cube's colour (shaded: red clearly above green and blue)."""
    r, g, b = (rgb[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 90) & (r > 2 * g) & (r > 2 * b)))


# --- the tool through MCP ------------------------------------------------------------------------


async def test_look_returns_a_320_by_240_png_block_and_only_its_description_in_the_json(robot: Client) -> None:
    result = await robot.call_tool("look", {})
    assert not result.is_error
    assert (
        isinstance(result.content[0], TextContent) and json.loads(result.content[0].text) == result.structured_content
    )
    rgb = picture(result)
    assert rgb.shape == (240, 320, 3)
    assert float(rgb.reshape(-1, 3).std(axis=0).mean()) > 10  # walls, floor and sky, not one colour
    data = result.structured_content
    assert data is not None
    assert data["image"] == {"mime_type": "image/png", "width": 320, "height": 240}
    assert (data["direction"], data["location"], data["caption"]) == ("ahead", "Front Door", None)
    assert len(json.dumps(data)) < 1000  # no pixels in the structured content


async def test_the_view_differs_between_directions_and_between_places(robot: Client) -> None:
    ahead = picture(await robot.call_tool("look", {"direction": "ahead"}))
    left = picture(await robot.call_tool("look", {"direction": "left"}))
    assert np.abs(ahead.astype(int) - left.astype(int)).mean() > 5
    await robot.call_tool("move_to", {"location": "Kitchen Area Left"})
    there = picture(await robot.call_tool("look", {"direction": "ahead"}))
    assert np.abs(ahead.astype(int) - there.astype(int)).mean() > 5


async def test_the_caption_comes_only_when_asked_and_names_what_the_picture_shows(robot: Client) -> None:
    plain = await robot.call_tool("look", {"direction": "cube"})
    assert plain.structured_content is not None and plain.structured_content["caption"] is None
    toward = await robot.call_tool("look", {"direction": "the cube", "caption": True})
    assert toward.structured_content is not None
    seen = toward.structured_content["caption"]
    assert [o["name"] for o in seen["objects"]] == ["cube"]
    assert seen["objects"][0]["where"] == "on Front Door floor"
    assert "cube" in seen["text"]
    assert red_pixels(picture(toward)) > 30  # the cube the caption names is in the picture
    away = await robot.call_tool("look", {"direction": "behind", "caption": True})
    assert away.structured_content is not None and away.structured_content["caption"]["objects"] == []
    assert red_pixels(picture(away)) == 0


async def test_looking_toward_a_location_turns_the_camera_to_what_stands_there(robot: Client) -> None:
    await robot.call_tool("move_to", {"location": "Kitchen Area Left"})
    result = await robot.call_tool("look", {"direction": "kitchen table", "caption": True})
    data = result.structured_content
    assert data is not None and data["direction"] == "toward Kitchen Table"
    assert data["caption"]["furniture"] == ["kitchen table"]
    assert [o["name"] for o in data["caption"]["objects"]] == ["mug"]
    assert "Kitchen Table" in data["caption"]["locations"]


async def test_a_direction_that_names_nothing_is_an_error_that_says_what_is_accepted(robot: Client) -> None:
    result = await robot.call_tool("look", {"direction": "Kitchen Tabel"})
    assert result.is_error and not any(isinstance(b, ImageContent) for b in result.content)
    text = result.content[0].text  # type: ignore[union-attr]
    assert "cannot look toward 'Kitchen Tabel'" in text and "Did you mean 'Kitchen Table'" in text
    assert "ahead, left, right, behind" in text and "mug" in text
    too_long = await robot.call_tool("look", {"direction": "x" * 500})
    assert too_long.is_error and "too long" in too_long.content[0].text  # type: ignore[union-attr]


async def test_look_is_published_read_only_with_its_size_in_the_description(robot: Client) -> None:
    tool = next(t for t in (await robot.list_tools()).tools if t.name == "look")
    assert tool.annotations is not None and tool.annotations.read_only_hint and not tool.annotations.open_world_hint
    assert "320x240 PNG" in (tool.description or "")
    assert set(tool.input_schema["properties"]) == {"direction", "caption", "robot_id"}  # every tool takes robot_id


# --- the rendering, without MCP ------------------------------------------------------------------


def test_looking_changes_nothing_in_the_world(world: World) -> None:
    session = RobotSession(SessionConfig(), world=world)
    before, steps = world.state(), world.steps
    result = session.call(look.TOOL, direction="mug", caption=True)
    assert result.image_bytes is not None and result.image_bytes.startswith(b"\x89PNG")
    assert world.state() == before and world.steps == steps


def test_render_camera_is_a_plain_function_of_the_world_at_any_size(world: World) -> None:
    png = camera.render_camera(world, direction="behind", width=160, height=120)
    assert Image.open(io.BytesIO(png)).size == (160, 120)
    with pytest.raises(ValueError, match="16 to 1024 pixels"):
        camera.render_camera(world, width=4000)


def test_the_png_encoder_round_trips_through_pillow() -> None:
    rgb = np.random.default_rng(0).integers(0, 256, size=(37, 53, 3), dtype=np.uint8)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(camera.encode_png(rgb)))), rgb)


# --- the client: pictures to vision models, a note to the others ---------------------------------

LOOK = ("look", {"direction": "cube"})
END = ("end_task", {"status": "success", "description": "look at the cube", "summary": "saw it"})


async def look_episode(robot: Client, fake: FakeLLM, model: str, *, vision: bool, trace: Trace) -> list[Any]:
    """One episode whose model looks at the cube, then ends the task; the requests the model got."""
    fake.script = [Turn(tool_calls=[LOOK]), Turn(tool_calls=[END])]
    tools = (await robot.list_tools()).tools
    settings = AgentSettings(model=model, api_base=fake.api_base(model), vision=vision, retries=0)
    result = await run_episode(
        robot, "Look at the cube.", settings, trace, system_prompt="You drive a robot.", tools=tools
    )
    assert result.outcome == "ended", result.error
    return fake.model_requests


@pytest.fixture
def fake() -> Iterator[FakeLLM]:
    with FakeLLM() as server:
        yield server
        assert not server.problems, server.problems


async def test_a_vision_run_shows_the_picture_in_a_user_message_after_the_tool_message(
    robot: Client, fake: FakeLLM, tmp_path: Path
) -> None:
    trace = Trace(tmp_path / "run.jsonl")
    requests = await look_episode(robot, fake, "openai/fake-vision", vision=True, trace=trace)
    trace.close()
    assert requests[0].images() == []
    messages = requests[1].messages
    roles = [m["role"] for m in messages]
    assert roles == ["system", "user", "assistant", "tool", "user"]
    assert IMAGE_OMITTED not in messages[3]["content"]
    assert [role for role, _ in requests[1].images()] == ["user"]
    (_, data), *_ = requests[1].images()
    shown = Image.open(io.BytesIO(base64.b64decode(data)))
    assert shown.size == (320, 240)
    # The trace keeps a file next to it, not the bytes.
    results = [e for e in read_trace(tmp_path / "run.jsonl") if isinstance(e, ToolResult) and e.name == "look"]
    assert [r.images for r in results] == [["run.images/0001-look.png"]] and results[0].images_sent
    assert (tmp_path / "run.images" / "0001-look.png").read_bytes() == base64.b64decode(data)
    assert "iVBOR" not in (tmp_path / "run.jsonl").read_text()


async def test_anthropic_gets_the_picture_as_its_own_image_block(robot: Client, fake: FakeLLM) -> None:
    requests = await look_episode(robot, fake, "anthropic/claude-fake", vision=True, trace=Trace())
    images = requests[1].images()
    assert len(images) == 1 and images[0][0] == "user"
    assert Image.open(io.BytesIO(base64.b64decode(images[0][1]))).size == (320, 240)


async def test_a_text_only_model_is_not_offered_the_camera(robot: Client, fake: FakeLLM) -> None:
    fake.script = [Turn(tool_calls=[LOOK]), Turn(tool_calls=[END])]
    tools = (await robot.list_tools()).tools
    settings = AgentSettings(model="openai/fake-text", api_base=fake.api_base("openai/fake-text"), retries=0)
    await run_episode(robot, "Look at the cube.", settings, Trace(), system_prompt="You drive a robot.", tools=tools)
    offered = {t["function"]["name"] for t in fake.model_requests[0].body["tools"]}
    assert "look" not in offered and "look_around" in offered
    refused = fake.model_requests[1].messages[3]["content"]
    assert "there is no tool called 'look'" in refused and all(r.images() == [] for r in fake.model_requests)


async def test_a_text_only_run_gets_a_one_line_note_instead_of_a_picture(
    robot: Client, fake: FakeLLM, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A picture from a tool the client does not know as a camera (another server's) still never reaches
    a text-only model."""
    from robocog.shared import provenance

    monkeypatch.setattr(provenance, "VISION_TOOLS", frozenset())  # which tools a model is offered
    trace = Trace()
    requests = await look_episode(robot, fake, "openai/fake-text", vision=False, trace=trace)
    assert all(r.images() == [] for r in requests)
    messages = requests[1].messages
    assert [m["role"] for m in messages] == ["system", "user", "assistant", "tool"]
    assert messages[3]["content"].splitlines()[-1] == IMAGE_OMITTED
    result = next(e for e in trace.events if isinstance(e, ToolResult) and e.name == "look")
    assert result.images == ["memory/0001-look.png"] and not result.images_sent
    assert trace.images["memory/0001-look.png"].startswith(b"\x89PNG")
