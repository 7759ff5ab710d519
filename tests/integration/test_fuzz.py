"""Attack the tools: a Hypothesis state machine drives every tool through an in-memory MCP client
with valid, made-up and hostile arguments, and checks after every step that the world holds together
and that the server still answers.

Hostile means: names from the scene and names made up, wrong types, missing and unknown arguments,
texts of up to a few MB, control characters, lone surrogates and other odd unicode, negative and huge
numbers, NaN, deeply nested values, unknown tools, resource URIs that name nothing, and random
reset_world / begin_task / end_task in between. After every step, through what a client can see
(the `robocog://world/state` resource): every object of the scene is still there, no place position
holds two objects, at most one object is held, a held object rests on no position; and a trivial call
is answered. A call may be refused (a tool error or a JSON-RPC error) but never with a traceback, and
the server may log no unexpected exception while answering it.

The server is built once for the module (building the world takes seconds) and reset before every
example. The budget is short in `make test`; `make fuzz` runs it long: ROBOCOG_FUZZ=long (random
seeds, failures kept in .cache/hypothesis), or ROBOCOG_FUZZ_EXAMPLES / ROBOCOG_FUZZ_STEPS.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar

import anyio
import pytest
from anyio.from_thread import BlockingPortal, start_blocking_portal
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.database import DirectoryBasedExampleDatabase
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule, run_state_machine_as_test
from mcp import Client
from mcp.shared.exceptions import MCPError
from mcp_types import CallToolResult

from robocog.server.app import build_server
from robocog.server.config import SessionConfig
from robocog.shared.results import WorldState
from tests.helpers import ROOT
from tests.hostile_inputs import MADE_UP_TOOLS, NUMBERS, ODD_TEXTS, PIECES, SIZES, nested, repeat
from tests.world_invariants import broken_invariants

#: A call that takes longer than this is a hung server (the largest hostile text is a few MB).
CALL_TIMEOUT_S = 120.0


def fuzz_settings() -> settings:
    """Short and seeded in `make test`; long, random and remembered with ROBOCOG_FUZZ=long."""
    long = os.environ.get("ROBOCOG_FUZZ") == "long"
    examples = int(os.environ.get("ROBOCOG_FUZZ_EXAMPLES", 250 if long else 25))
    steps = int(os.environ.get("ROBOCOG_FUZZ_STEPS", 50 if long else 20))
    database = DirectoryBasedExampleDatabase(ROOT / ".cache" / "hypothesis")
    return settings(
        max_examples=examples,
        stateful_step_count=steps,
        deadline=None,
        derandomize=not long,
        database=database if long else None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    )


# --- hostile values, as Hypothesis strategies --------------------------------------------------------

long_texts = st.builds(repeat, st.sampled_from(PIECES), st.sampled_from(SIZES))
odd_texts = st.one_of(
    st.sampled_from(ODD_TEXTS),
    st.text(st.characters(exclude_categories=()), max_size=40),  # surrogates and control characters too
    long_texts,
)
numbers = st.one_of(st.integers(-100, 100), st.sampled_from(NUMBERS))
scalars = st.one_of(
    st.none(),
    st.booleans(),
    numbers,
    st.floats(allow_nan=True, allow_infinity=True),
    odd_texts,
)
values = st.one_of(
    st.recursive(
        scalars,
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
        max_leaves=6,
    ),
    st.integers(20, 200).map(nested),  # the client refuses to serialise 255 levels or more
    st.integers(1_000, 200_000).map(lambda n: ["mug"] * n),
)


def mostly(valid: st.SearchStrategy[Any], hostile: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    """`valid` three times in four, else `hostile`: a run of valid calls is what reaches deep states."""
    return st.one_of(valid, valid, valid, hostile)


def names(valid: list[str]) -> st.SearchStrategy[str]:
    """Mostly names of the scene, else near misses and odd texts."""
    exact = st.sampled_from(valid)
    return st.one_of(exact, exact, exact.map(str.upper), exact.map(lambda s: f" {s}\n"), odd_texts)


# --- the robot under attack ------------------------------------------------------------------------


class ErrorLog(logging.Handler):
    """Keeps the records at ERROR and above that anything in the process logs (the SDK logs a tool's
    unexpected exception there with its traceback)."""

    def __init__(self) -> None:
        super().__init__(logging.ERROR)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@dataclass
class Robot:
    """An in-memory eval-profile server, its client held open on a portal's event loop, and the names
    of its scene."""

    portal: BlockingPortal
    client: Client
    log: ErrorLog
    objects: list[str] = field(default_factory=list)
    locations: list[str] = field(default_factory=list)
    positions: list[tuple[str, str]] = field(default_factory=list)
    #: tool name -> its input schema's properties
    tools: dict[str, dict[str, Any]] = field(default_factory=dict)

    def call(self, tool: str, arguments: Any) -> CallToolResult | None:
        """One tool call; the result, or None when it was refused with a JSON-RPC error. Fails the test
        on a traceback in the answer or an unexpected error the server logged while answering."""
        self.log.records.clear()
        try:
            result: CallToolResult | None = self.portal.call(self._call_tool, tool, arguments)
        except MCPError as exc:
            assert "Traceback" not in str(exc), f"{tool}: a traceback in the JSON-RPC error: {exc}"
            result = None
        logged = [
            f"{r.name}: {r.getMessage()} ({r.exc_info[1]!r}, from {r.exc_info[1].__cause__!r})"
            if r.exc_info and r.exc_info[1]
            else r.getMessage()
            for r in self.log.records
        ]
        assert not logged, f"{tool}({brief(arguments)}): the server logged an unexpected error: {logged}"
        if result is not None and result.is_error:
            text = " ".join(getattr(c, "text", "") for c in result.content)
            assert "Traceback" not in text, f"{tool}: a traceback in the tool error: {text[:2000]}"
        return result

    async def _call_tool(self, tool: str, arguments: Any) -> CallToolResult:
        with anyio.fail_after(CALL_TIMEOUT_S):
            return await self.client.call_tool(tool, arguments)

    def read(self, uri: str) -> str | None:
        """A resource's text, or None when the server refused the URI with a JSON-RPC error."""
        self.log.records.clear()
        try:
            text: str | None = self.portal.call(self._read, uri)
        except MCPError as exc:
            assert "Traceback" not in str(exc), f"{uri}: a traceback in the JSON-RPC error: {exc}"
            text = None
        assert not self.log.records, f"{uri[:200]}: the server logged an unexpected error: {self.log.records}"
        return text

    async def _read(self, uri: str) -> str:
        with anyio.fail_after(CALL_TIMEOUT_S):
            result = await self.client.read_resource(uri, cache_mode="bypass")
        return str(getattr(result.contents[0], "text", ""))

    def state(self) -> WorldState:
        text = self.read("robocog://world/state")
        assert text is not None, "the world state resource was refused"
        return WorldState.model_validate_json(text)

    def ok(self, tool: str, arguments: dict[str, Any]) -> dict[str, Any]:
        result = self.call(tool, arguments)
        assert result is not None and not result.is_error and result.structured_content is not None, (
            f"{tool}({arguments}) failed: {result}"
        )
        return dict(result.structured_content)

    def fresh(self) -> None:
        """The start of an example: the seeded start state, an empty memory, a new T1 episode."""
        self.ok("reset_world", {"seed": 0})
        self.ok("clear_memory", {})
        self.ok("begin_task", {"task_id": "T1"})


def brief(value: Any, limit: int = 300) -> str:
    """A short, printable description of a (possibly huge) value."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} chars)"


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Robot]:
    data = tmp_path_factory.mktemp("fuzz") / "memory"
    server = build_server(SessionConfig(seed=0, data_dir=data), profile="eval")
    log = ErrorLog()
    logging.getLogger().addHandler(log)
    try:
        with (
            start_blocking_portal(backend="asyncio") as portal,
            portal.wrap_async_context_manager(Client(server)) as client,
        ):
            robot = Robot(portal, client, log)
            tools = portal.call(client.list_tools)
            robot.tools = {t.name: dict(t.input_schema.get("properties", {})) for t in tools.tools}
            world_map = json.loads(robot.read("robocog://world/map") or "{}")
            robot.locations = sorted(loc["name"] for loc in world_map["locations"])
            robot.positions = sorted((p["location"], p["position"]) for p in world_map["place_positions"])
            robot.objects = sorted(o.object for o in robot.state().objects)
            assert robot.objects and robot.locations and robot.positions
            yield robot
    finally:
        logging.getLogger().removeHandler(log)


class ToolFuzz(RuleBasedStateMachine):
    """Random and hostile tool calls on one robot; the world must hold together after each."""

    robot: ClassVar[Robot]

    def __init__(self) -> None:
        super().__init__()
        self.robot.fresh()

    # valid actions, so that the world moves through many states

    @rule(data=st.data())
    def move_to(self, data: st.DataObject) -> None:
        location = data.draw(st.sampled_from(self.robot.locations), label="location")
        moved = self.robot.ok("move_to", {"location": location})  # the map is connected: always reachable
        assert moved["location"] == location

    @rule(data=st.data())
    def grab(self, data: st.DataObject) -> None:
        name = data.draw(names(self.robot.objects), label="object")
        result = self.robot.call("grab", {"object": name})
        if result is not None and not result.is_error:  # names are matched leniently (case, spaces)
            assert result.structured_content is not None
            assert self.robot.state().robot.holding == result.structured_content["holding"] in self.robot.objects

    @rule(data=st.data())
    def place(self, data: st.DataObject) -> None:
        location, position = data.draw(st.sampled_from(self.robot.positions), label="position")
        location = data.draw(st.one_of(st.just(location), names(self.robot.locations)), label="location")
        position = data.draw(st.one_of(st.just(position), odd_texts), label="position name")
        held = self.robot.state().robot.holding
        result = self.robot.call("place", {"location": location, "position": position})
        if result is not None and not result.is_error:
            assert result.structured_content is not None
            where = (result.structured_content["location"], result.structured_content["position"])
            after = self.robot.state()
            assert after.robot.holding is None
            assert [p.occupied_by for p in after.positions if (p.location, p.position) == where] == [held]

    # harness controls at random

    @rule(seed=st.one_of(st.none(), st.integers(0, 2**32 - 1), numbers), randomize=st.booleans())
    def reset_world(self, seed: int | None, randomize: bool) -> None:
        self.robot.call("reset_world", {"seed": seed, "randomize": randomize})

    @rule(task_id=mostly(st.sampled_from(["T1", "T2"]), odd_texts), keep=st.booleans())
    def begin_task(self, task_id: str, keep: bool) -> None:
        self.robot.call("begin_task", {"task_id": task_id, "keep_scratchpad": keep})

    @rule(
        status=mostly(st.sampled_from(["success", "failure"]), odd_texts),
        description=mostly(st.just("Put away all the items into the shelf."), odd_texts),
        summary=mostly(st.just("done"), odd_texts),
    )
    def end_task(self, status: str, description: str, summary: str) -> None:
        self.robot.call("end_task", {"status": status, "description": description, "summary": summary})

    @rule(task_id=mostly(st.sampled_from(["T1", "T2"]), odd_texts))
    def check_task(self, task_id: str) -> None:
        self.robot.call("check_task", {"task_id": task_id})

    @rule()
    def clear_memory(self) -> None:
        self.robot.ok("clear_memory", {})

    @rule(query=odd_texts, k=st.one_of(st.none(), numbers))
    def search_memory(self, query: str, k: int | None) -> None:
        self.robot.call("search_memory", {"query": query} if k is None else {"query": query, "k": k})

    @rule(text=odd_texts)
    def add_to_scratchpad(self, text: str) -> None:
        self.robot.call("add_to_scratchpad", {"text": text})

    # hostile calls of any tool

    @rule(data=st.data())
    def any_tool_with_hostile_arguments(self, data: st.DataObject) -> None:
        """A published tool with each of its arguments present or not, of any type or an odd text,
        plus unknown arguments."""
        tool = data.draw(st.sampled_from(sorted(self.robot.tools)), label="tool")
        properties = self.robot.tools[tool]
        arguments: dict[str, Any] = {}
        for name in properties:
            if data.draw(st.booleans(), label=f"give {name}"):
                hint = {"object": self.robot.objects, "location": self.robot.locations}.get(name)
                strategy = st.one_of(values, names(hint)) if hint else values
                arguments[name] = data.draw(strategy, label=name)
        arguments |= data.draw(st.dictionaries(st.text(max_size=12), values, max_size=2), label="unknown arguments")
        self.robot.call(tool, arguments)

    @rule(data=st.data())
    def unknown_tool_or_no_arguments(self, data: st.DataObject) -> None:
        tool = data.draw(st.one_of(st.sampled_from(MADE_UP_TOOLS), st.sampled_from(sorted(self.robot.tools))))
        arguments = data.draw(
            st.one_of(st.none(), st.just({}), st.dictionaries(st.text(max_size=8), values, max_size=3))
        )
        self.robot.call(tool, arguments)

    @rule(data=st.data())
    def read_a_resource(self, data: st.DataObject) -> None:
        # No lone surrogates here: the client itself cannot encode them into the request's headers.
        name = data.draw(st.one_of(st.sampled_from(self.robot.objects + self.robot.locations), st.text(max_size=30)))
        template = data.draw(st.sampled_from(["robocog://objects/{}", "robocog://locations/{}", "robocog://{}"]))
        self.robot.read(template.format(name))

    # after every step

    @invariant()
    def the_world_holds_together(self) -> None:
        problems = broken_invariants(self.robot.state(), self.robot.objects, self.robot.locations)
        assert not problems, "; ".join(problems)

    @invariant()
    def the_server_answers(self) -> None:
        self.robot.ok("view_scratchpad", {})


def test_hostile_tool_calls_never_break_the_world_nor_the_server(robot: Robot) -> None:
    ToolFuzz.robot = robot
    run_state_machine_as_test(ToolFuzz, settings=fuzz_settings())


def test_the_invariants_catch_a_broken_world(robot: Robot) -> None:
    """The checks can fail: a held object also on a position, a lost object and a doubled one."""
    robot.fresh()
    state = robot.state()
    assert broken_invariants(state, robot.objects, robot.locations) == []
    on = next(o for o in state.objects if o.state == "on_position")
    broken = state.model_copy(deep=True)
    broken.robot.holding = on.object
    problems = broken_invariants(broken, robot.objects, robot.locations)
    assert any("held" in p for p in problems)
    broken = state.model_copy(deep=True)
    broken.objects = [*broken.objects[1:], broken.objects[1]]
    problems = broken_invariants(broken, robot.objects, robot.locations)
    assert any("not conserved" in p for p in problems)
