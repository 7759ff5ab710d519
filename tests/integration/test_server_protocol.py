"""The MCP protocol beyond tools, through in-memory clients: logging, completions, resource
templates, prompt arguments and subscriptions.

Logging (`logging/setLevel`) and `resources/subscribe` exist on the handshake protocol versions,
which desktop clients and the conformance suite speak: those tests connect with `mode="legacy"`.
From 2026-07-28 on, a request carries its own log level and subscriptions are
`subscriptions/listen` streams; one test each covers that era.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import anyio
import pytest
from mcp import Client
from mcp.shared.exceptions import MCPError
from mcp_types import LoggingMessageNotificationParams, PromptReference, ResourceTemplateReference

from robocog.server.app import build_server
from robocog.server.config import SessionConfig

# The client's helpers for the handshake era's logging/setLevel and resources/subscribe warn that
# 2026-07-28 deprecates them; the server serves both on purpose.
pytestmark = [pytest.mark.anyio, pytest.mark.filterwarnings("ignore::mcp.shared.exceptions.MCPDeprecationWarning")]

STATE = "robocog://world/state"
IMAGE = "robocog://world/image"
MAP = "robocog://world/map"


@dataclass
class Inbox:
    """What the server sent the client besides responses."""

    logs: list[LoggingMessageNotificationParams] = field(default_factory=list)
    updated: list[str] = field(default_factory=list)

    async def on_log(self, params: LoggingMessageNotificationParams) -> None:
        self.logs.append(params)

    async def on_message(self, message: Any) -> None:
        if getattr(message, "method", None) == "notifications/resources/updated":
            self.updated.append(str(message.params.uri))

    def log_texts(self) -> list[str]:
        return [str(p.data) for p in self.logs]


async def until(condition: Callable[[], bool], timeout_s: float = 5.0) -> None:
    """Wait for a notification that is sent beside a response, not before it."""
    with anyio.fail_after(timeout_s):
        while not condition():
            await anyio.sleep(0.01)


@pytest.fixture
def inbox() -> Inbox:
    return Inbox()


@pytest.fixture
async def desktop(tmp_path: Path, inbox: Inbox) -> AsyncIterator[Client]:
    """A client on the handshake protocol (as desktop assistants and the conformance suite are)."""
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    client = Client(server, raise_exceptions=True, mode="legacy", logging_callback=inbox.on_log)
    client.message_handler = inbox.on_message
    async with client:
        yield client


@pytest.fixture
async def modern(tmp_path: Path, inbox: Inbox) -> AsyncIterator[Client]:
    """A client on 2026-07-28, asking for log records from "notice" up on every request."""
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"))
    async with Client(server, raise_exceptions=True, log_level="notice", logging_callback=inbox.on_log) as client:
        yield client


def text(result: Any) -> str:
    return str(result.contents[0].text)


# --- capabilities ----------------------------------------------------------------------------------


async def test_the_server_declares_logging_completions_and_subscriptions(desktop: Client, modern: Client) -> None:
    assert desktop.server_capabilities.model_dump(mode="json", by_alias=True, exclude_none=True) == {
        "completions": {},
        "experimental": {"robocog/driver": {"issued": True, "handle": True}},  # contract 3.0 and 4.0: who drives
        "logging": {},
        "prompts": {"listChanged": False},
        "resources": {"listChanged": False, "subscribe": True},
        "tools": {"listChanged": False},
    }
    # from 2026-07-28 on, change notifications (and with them `subscribe`) go over subscriptions/listen
    assert modern.server_capabilities.model_dump(mode="json", by_alias=True, exclude_none=True) == {
        "completions": {},
        "experimental": {"robocog/driver": {"issued": True, "handle": True}},
        "logging": {},
        "prompts": {"listChanged": True},
        "resources": {"listChanged": True, "subscribe": True},
        "tools": {"listChanged": True},
    }


# --- logging ---------------------------------------------------------------------------------------


async def test_nothing_is_logged_to_a_client_that_chose_no_level(desktop: Client, inbox: Inbox) -> None:
    await desktop.call_tool("grab", {"object": "tv"})
    await desktop.call_tool("look_around", {})
    assert inbox.logs == []


async def test_set_level_sends_the_start_up_records_then_each_calls_own(desktop: Client, inbox: Inbox) -> None:
    await desktop.call_tool("look_around", {})  # the robot is ready
    assert await desktop.set_logging_level("info") is not None
    await until(lambda: any(t.startswith("robot ready") for t in inbox.log_texts()))
    assert any(t.startswith("episodic memory: embedded ChromaDB") for t in inbox.log_texts())
    inbox.logs.clear()
    await desktop.call_tool("grab", {"object": "tv"})
    await desktop.call_tool("begin_task", {"task_id": "T9"})
    await desktop.call_tool("end_task", {"status": "failure", "description": "Fetch the tv.", "summary": "No."})
    assert [(p.level, p.logger) for p in inbox.logs] == [
        ("notice", "robocog.server.session"),
        ("notice", "robocog.server.session"),
        ("info", "robocog.server.session"),
    ]
    assert inbox.logs[0].data == "grab failed: The tv cannot be grasped: it is too large or heavy for the robot."
    assert inbox.logs[1].data == "begin_task: bad input: unknown task 'T9'; known tasks: T1, T2"
    assert inbox.logs[2].data == "episode 1 ended: believed failure after 3 tool calls"


async def test_a_higher_level_filters_the_records_below_it(desktop: Client, inbox: Inbox) -> None:
    await desktop.call_tool("look_around", {})
    await desktop.set_logging_level("warning")
    await desktop.call_tool("grab", {"object": "tv"})
    await desktop.call_tool("reset_world", {})  # "episode 2 begins": info
    assert inbox.logs == []
    await desktop.set_logging_level("debug")
    await desktop.call_tool("grab", {"object": "tv"})
    await desktop.call_tool("reset_world", {})
    assert [p.level for p in inbox.logs[-2:]] == ["notice", "info"]
    assert inbox.logs[-1].data == "episode 3 begins"


async def test_a_2026_client_gets_the_records_its_requests_ask_for(modern: Client, inbox: Inbox) -> None:
    await modern.call_tool("end_task", {"status": "success", "description": "Nothing.", "summary": "x"})  # info
    await modern.call_tool("move_to", {"location": "Garage"})  # notice
    assert [(p.level, str(p.data).split(":")[0]) for p in inbox.logs] == [("notice", "move_to failed")]


# --- resource templates ----------------------------------------------------------------------------


async def test_templates_serve_one_object_and_one_location(desktop: Client) -> None:
    templates = {t.uri_template: t for t in (await desktop.list_resource_templates()).resource_templates}
    assert set(templates) == {"robocog://objects/{name}", "robocog://locations/{name}"}
    mug = json.loads(text(await desktop.read_resource("robocog://objects/mug")))
    assert (mug["location"], mug["position"], mug["state"], mug["graspable"]) == (
        "Kitchen Table",
        "middle",
        "on_position",
        True,
    )
    assert json.loads(text(await desktop.read_resource("robocog://objects/tv")))["graspable"] is False
    shelf = json.loads(text(await desktop.read_resource("robocog://locations/Kitchen%20Shelf")))
    assert shelf["neighbours"] == ["Kitchen Area Left"] and shelf["robot_here"] is False
    assert [(p["position"], p["occupied_by"]) for p in shelf["place_positions"]] == [
        ("top", None),
        ("middle", None),
        ("bottom", None),
    ]
    door = json.loads(text(await desktop.read_resource("robocog://locations/Front%20Door")))
    assert (door["robot_here"], door["objects"]) == (True, ["cube"])


async def test_an_unknown_name_in_a_template_names_the_known_ones(desktop: Client) -> None:
    with pytest.raises(MCPError, match="no object called 'plate'; objects: cube, box, mug, tv"):
        await desktop.read_resource("robocog://objects/plate")
    with pytest.raises(MCPError, match="no location called 'Garage'"):
        await desktop.read_resource("robocog://locations/Garage")


# --- completions and prompt arguments --------------------------------------------------------------


async def complete(
    client: Client, ref: PromptReference | ResourceTemplateReference, name: str, value: str
) -> list[str]:
    return (await client.complete(ref, {"name": name, "value": value})).completion.values


async def test_template_names_complete_from_the_scene(desktop: Client) -> None:
    objects = ResourceTemplateReference(type="ref/resource", uri="robocog://objects/{name}")
    locations = ResourceTemplateReference(type="ref/resource", uri="robocog://locations/{name}")
    assert await complete(desktop, objects, "name", "") == ["cube", "box", "mug", "tv"]
    assert await complete(desktop, objects, "name", "M") == ["mug"]
    assert await complete(desktop, locations, "name", "kitchen s") == ["Kitchen Shelf"]
    # names that begin with it first, then names with a later word that does
    assert await complete(desktop, locations, "name", "Li") == ["Living Room Door", "Living Room", "Living Room TV"]
    assert await complete(desktop, locations, "name", "DOOR") == [
        "Front Door",
        "Hallway Area Door",
        "Kitchen Door",
        "Living Room Door",
    ]
    assert await complete(desktop, objects, "name", "plate") == []


async def test_the_bring_prompt_takes_an_object_and_a_location(desktop: Client) -> None:
    bring = next(p for p in (await desktop.list_prompts()).prompts if p.name == "bring")
    assert [(a.name, a.required) for a in bring.arguments or []] == [("object", True), ("location", True)]
    result = await desktop.get_prompt("bring", {"object": "mug", "location": "Kitchen Shelf"})
    assert result.messages[0].content.text == "Bring the mug to Kitchen Shelf."  # type: ignore[union-attr]
    prompt = PromptReference(type="ref/prompt", name="bring")
    assert await complete(desktop, prompt, "object", "") == ["cube", "box", "mug"]  # never the tv
    assert await complete(desktop, prompt, "location", "kitchen t") == ["Kitchen Table"]
    assert await complete(desktop, PromptReference(type="ref/prompt", name="T1"), "object", "m") == []


# --- subscriptions ---------------------------------------------------------------------------------


async def test_a_subscriber_hears_of_every_action_that_changes_the_world(desktop: Client, inbox: Inbox) -> None:
    await desktop.subscribe_resource(STATE)
    await desktop.subscribe_resource(IMAGE)
    await desktop.subscribe_resource(MAP)  # accepted; the map never changes
    await desktop.call_tool("look_around", {})
    await desktop.call_tool("move_to", {"location": "Kitchen Table"})
    await until(lambda: len(inbox.updated) == 2)
    assert sorted(inbox.updated) == [IMAGE, STATE]
    await desktop.call_tool("view_scratchpad", {})
    await desktop.call_tool("grab", {"object": "cube"})  # fails: nothing changed
    await desktop.call_tool("grab", {"object": "mug"})
    await until(lambda: len(inbox.updated) == 4)
    await desktop.unsubscribe_resource(IMAGE)
    await desktop.call_tool("reset_world", {})
    await until(lambda: len(inbox.updated) == 5)
    await anyio.sleep(0.05)
    assert inbox.updated[4:] == [STATE]


async def test_a_subscription_to_one_object_is_updated_too(desktop: Client, inbox: Inbox) -> None:
    await desktop.subscribe_resource("robocog://objects/cube")
    await desktop.call_tool("grab", {"object": "cube"})
    await until(lambda: inbox.updated == ["robocog://objects/cube"])


async def test_a_2026_client_listens_for_world_updates(modern: Client) -> None:
    async with modern.listen(resource_subscriptions=[STATE]) as subscription:
        await modern.call_tool("move_to", {"location": "Living Room"})
        with anyio.fail_after(5):
            async for event in subscription:
                assert getattr(event, "uri", None) == STATE
                break


async def test_world_updates_are_published_only_while_someone_listens(
    modern: Client, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcp.server.mcpserver import Context

    published: list[str] = []
    real = Context.notify_resource_updated

    async def counted(self: Context[Any], uri: Any) -> None:
        published.append(str(uri))
        await real(self, uri)

    monkeypatch.setattr(Context, "notify_resource_updated", counted)
    await modern.call_tool("move_to", {"location": "Living Room"})
    assert published == []  # no listen stream: no event built
    async with modern.listen(resource_subscriptions=[STATE]) as subscription:
        await modern.call_tool("move_to", {"location": "Kitchen Table"})
        with anyio.fail_after(5):
            async for event in subscription:
                assert getattr(event, "uri", None) == STATE
                break
    assert STATE in published


async def test_a_call_collects_log_records_only_for_a_client_that_asked(
    desktop: Client, inbox: Inbox, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No level set: a call's records (a failed grab's notice) are not even turned into entries."""
    from robocog.server import clients

    made: list[Any] = []
    real = clients.LogEntry.of

    def counted(cls: type[clients.LogEntry], record: Any) -> clients.LogEntry:
        made.append(record)
        return real(record)

    monkeypatch.setattr(clients.LogEntry, "of", classmethod(counted))
    await desktop.call_tool("look_around", {})  # the robot is ready
    made.clear()
    await desktop.call_tool("grab", {"object": "tv"})
    assert made == [] and inbox.logs == []
    await desktop.set_logging_level("notice")
    await desktop.call_tool("grab", {"object": "tv"})
    assert len(made) == 1 and inbox.log_texts()[-1].startswith("grab failed")
