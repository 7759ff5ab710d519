"""The published contract: `robocog contract dump | check` (classification, exit codes, real servers over
stdio and HTTP), output conformance of every tool's results, and the pytest plugin for client authors."""

from __future__ import annotations

import copy
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robocog.agent.contract.check import dump_contract, shipped_contract_path, validate_structured
from robocog.agent.contract.diff import EXIT_BREAKING, EXIT_OK, EXIT_UNREACHABLE, Change, compare_contracts, report
from robocog.server.testing import RobocogWorld
from robocog.shared.protocol import FURNITURE_TOOLS
from tests.helpers import CONTRACT_DIR, T1_SEQUENCE, action_args, free_port, http_server

pytestmark = pytest.mark.anyio


def load(profile: str) -> dict[str, Any]:
    return json.loads((CONTRACT_DIR / f"{profile}.json").read_text(encoding="utf-8"))


def tool(contract: dict[str, Any], name: str) -> dict[str, Any]:
    return next(t for t in contract["tools"] if t["name"] == name)


def breaking(changes: list[Change]) -> list[str]:
    return [f"{c.where}: {c.what}" for c in changes if c.kind == "breaking"]


def compatible(changes: list[Change]) -> list[str]:
    return [f"{c.where}: {c.what}" for c in changes if c.kind == "compatible"]


# --- the published files -------------------------------------------------------------------------


def test_the_package_ships_the_contract_with_its_version_and_changelog() -> None:
    from robocog.shared.protocol import CONTRACT_VERSION

    for profile in ("default", "eval"):
        path = shipped_contract_path(profile)
        assert path == CONTRACT_DIR.resolve() / f"{profile}.json"
        assert load(profile)["contract"] == CONTRACT_VERSION
        assert set(load(profile)) == {
            "capabilities",
            "contract",
            "server",
            "tools",
            "resources",
            "resourceTemplates",
            "prompts",
        }
    assert f"## {CONTRACT_VERSION}" in (CONTRACT_DIR / "CHANGELOG.md").read_text(encoding="utf-8")


async def test_the_server_announces_the_contract_version(robocog_client: Client) -> None:
    from robocog.shared.protocol import CONTRACT_VERSION

    assert f"contract {CONTRACT_VERSION}" in (robocog_client.instructions or "")
    assert (await dump_contract(robocog_client))["contract"] == CONTRACT_VERSION


def test_an_identical_contract_has_no_differences() -> None:
    assert compare_contracts(load("eval"), load("eval")) == []


# --- classification ------------------------------------------------------------------------------


def test_a_new_tool_is_compatible_and_a_removed_one_breaking() -> None:
    live = load("eval")
    baseline = copy.deepcopy(live)
    baseline["tools"] = [t for t in baseline["tools"] if t["name"] != "view_scratchpad"]
    changes = compare_contracts(baseline, live)
    assert compatible(changes) == ["tool view_scratchpad: added"] and not breaking(changes)
    assert breaking(compare_contracts(live, baseline)) == ["tool view_scratchpad: removed (or renamed)"]


def test_a_capability_removed_is_breaking_and_one_added_compatible() -> None:
    live = load("default")
    assert {"tools", "resources.subscribe"} <= set(live["capabilities"])
    assert live["capabilities"] == sorted(live["capabilities"])
    baseline = copy.deepcopy(live)
    baseline["capabilities"] = [c for c in live["capabilities"] if c != "tools"]
    live["capabilities"].remove("resources.subscribe")
    changes = compare_contracts(baseline, live)
    assert breaking(changes) == ["capability resources.subscribe: removed"]
    assert compatible(changes) == ["capability tools: added"]


def test_arguments_newly_required_are_breaking_and_new_optional_ones_compatible() -> None:
    live = load("eval")
    baseline = copy.deepcopy(live)
    tool(baseline, "move_to")["inputSchema"]["required"] = []  # the server now requires `location`
    del tool(baseline, "place")["inputSchema"]["properties"]["position"]  # a new required argument
    tool(baseline, "place")["inputSchema"]["required"].remove("position")
    del tool(baseline, "search_memory")["inputSchema"]["properties"]["k"]  # a new optional argument
    changes = compare_contracts(baseline, live)
    assert breaking(changes) == [
        "tool move_to: argument 'location' newly required",
        "tool place: new required argument 'position'",
    ]
    assert compatible(changes) == ["tool search_memory: new optional argument 'k'"]
    # The other way round: an argument made optional is compatible, one removed breaking.
    back = compare_contracts(live, baseline)
    assert "tool move_to: argument 'location' now optional" in compatible(back)
    assert "tool search_memory: argument 'k' removed" in breaking(back)


def test_types_enums_bounds_and_annotations() -> None:
    live = load("eval")
    baseline = copy.deepcopy(live)
    props = tool(baseline, "reset_world")["inputSchema"]["properties"]
    props["seed"]["anyOf"].append({"type": "string"})  # the server accepts fewer types now
    props["memory_labels"]["anyOf"][0]["enum"].append("guessed")  # an enum value removed
    props["search_k"]["anyOf"][0]["maximum"] = 50  # a bound tightened
    tool(baseline, "move_to")["annotations"]["readOnlyHint"] = True  # read-only → not read-only
    tool(baseline, "grab")["description"] = "an older description"
    changes = compare_contracts(baseline, live)
    assert breaking(changes) == [
        "tool move_to: annotation readOnlyHint True → False",
        "tool reset_world: argument 'memory_labels': value(s) \"guessed\" no longer accepted",
        "tool reset_world: argument 'search_k': maximum 50 → 20",
        "tool reset_world: argument 'seed' narrowed: integer | null | string → integer | null",
    ]
    assert compatible(changes) == ["tool grab: description changed"]
    back = compare_contracts(live, baseline)
    assert not breaking(back)
    assert "tool reset_world: argument 'seed' widened: integer | null → integer | null | string" in compatible(back)


def test_output_fields_removed_or_retyped_are_breaking_and_new_ones_compatible() -> None:
    live = load("eval")
    baseline = copy.deepcopy(live)
    schema = tool(baseline, "grab")["outputSchema"]
    schema["properties"]["weight_kg"] = {"type": "number"}  # gone from the server
    schema["properties"]["message"]["type"] = "integer"  # the server now says a string
    del tool(baseline, "view_scratchpad")["outputSchema"]["properties"]["entries"]  # new on the server
    tool(baseline, "view_scratchpad")["outputSchema"]["required"].remove("entries")
    changes = compare_contracts(baseline, live)
    assert breaking(changes) == [
        "tool grab: output field 'message' retyped: integer → string",
        "tool grab: output field 'weight_kg' removed",
    ]
    assert compatible(changes) == ["tool view_scratchpad: new output field 'entries'"]


def test_nested_output_fields_are_compared_through_refs() -> None:
    live = load("eval")
    baseline = copy.deepcopy(live)
    defs = tool(baseline, "look_around")["outputSchema"]["$defs"]
    defs["LocationView"]["properties"]["area_m2"] = {"type": "number"}
    assert breaking(compare_contracts(baseline, live)) == [
        "tool look_around: output field 'locations[].area_m2' removed"
    ]


def test_resources_templates_and_prompts() -> None:
    baseline: dict[str, Any] = {
        "contract": "1.0",
        "tools": [],
        "resources": [{"uri": "x://a", "name": "a", "mimeType": "text/plain"}, {"uri": "x://b", "name": "b"}],
        "resourceTemplates": [{"uriTemplate": "x://t/{id}", "name": "t"}],
        "prompts": [{"name": "p", "arguments": [{"name": "topic", "required": False}, {"name": "tone"}]}],
    }
    live = copy.deepcopy(baseline)
    live["contract"] = "2.0"
    live["resources"][0]["mimeType"] = "application/json"
    live["resources"].pop()
    live["resourceTemplates"].append({"uriTemplate": "x://u/{id}", "name": "u"})
    live["prompts"][0]["arguments"] = [{"name": "topic", "required": True}, {"name": "tone"}, {"name": "style"}]
    changes = compare_contracts(baseline, live)
    assert breaking(changes) == [
        "resource x://a: MIME type text/plain → application/json",
        "resource x://b: removed (or renamed)",
        "prompt p: argument 'topic' newly required",
    ]
    assert compatible(changes) == [
        "contract: version 1.0 → 2.0",
        "resource template x://u/{id}: added",
        "prompt p: new optional argument 'style'",
    ]


def test_report_exits_by_the_worst_change(capsys: pytest.CaptureFixture[str]) -> None:
    assert report([Change("compatible", "tool a", "added")], "base.json", "live") == EXIT_OK
    assert report([Change("breaking", "tool b", "removed (or renamed)")], "base.json", "live") == EXIT_BREAKING
    out = capsys.readouterr().out
    assert "compatible  tool a: added" in out and "BREAKING    tool b: removed (or renamed)" in out


# --- output conformance --------------------------------------------------------------------------


async def test_every_tool_result_conforms_to_its_output_schema(
    robocog_client: Client, robocog_world: RobocogWorld
) -> None:
    """Every tool on success and failure paths; structured content always validates against outputSchema."""
    tools = {t.name: t for t in (await robocog_client.list_tools()).tools}
    succeeded: set[str] = set()
    failed: set[str] = set()

    async def call(name: str, ok: bool, **arguments: Any) -> None:
        result = await robocog_client.call_tool(name, arguments)
        assert bool(result.is_error) != ok, (name, arguments, result.content)
        data = result.structured_content
        schema = tools[name].output_schema
        assert schema, name
        if ok or data is not None:  # a failed action has structured content; a rejected argument has text only
            assert data is not None, (name, arguments)
            assert validate_structured(schema, data) == [], (name, arguments, data)
        (succeeded if ok else failed).add(name)

    await call("look_around", True)
    await call("view_scratchpad", True)
    await call("add_to_scratchpad", True, text="Plan: the cube first.")
    await call("add_to_scratchpad", False, text="x" * 5000)
    await call("move_to", False, location="Kitchen Shelve")
    await call("grab", False, object="mug")
    await call("place", False, location="Front Door", position="floor")
    await call("grab", True, object="cube")
    await call("move_to", True, location="Kitchen Shelf")
    await call("place", False, location="Kitchen Shelf", position="attic")
    await call("place", True, location="Kitchen Shelf", position="top")
    await call("search_memory", True, query="put things away")
    await call("search_memory", False, query="x", k=0)
    await call("look", True, direction="Kitchen Shelf", caption=True)
    await call("look", False, direction="attic")
    await call("end_task", False, status="done", description="x", summary="y")
    await call("end_task", True, status="success", description="Put the cube away.", summary="done")
    await call("check_task", True, task_id="T1")
    await call("check_task", False, task_id="T9")
    await call("begin_task", True, task_id="T1")
    await call("begin_task", False, task_id="T9")
    await call("reset_world", True, seed=1)
    await call("reset_world", False, search_k=0)
    await call("clear_memory", True)
    await call("clear_memory", False, drop=True)  # the server's own namespace cannot be dropped
    await call("open", False, furniture="kitchen_shelf")  # the paper's household has nothing that opens
    await call("close", False, furniture="fridge")
    await call("robot_view", True, camera_frame=True)  # the robot app's own read
    await call("robot_view", False, scene="maybe")
    # open and close succeed in a world with containers: the next test.
    assert succeeded == set(tools) - FURNITURE_TOOLS
    # every tool takes robot_id (a robot handle, for clients without a session); its own arguments can be wrong
    with_arguments = {n for n, t in tools.items() if set(t.input_schema.get("properties", {})) - {"robot_id"}}
    assert with_arguments <= failed


async def test_open_and_close_results_conform_to_their_output_schema(tmp_path: Path) -> None:
    """open and close in kitchen_plus, on their success and failure paths, and look_around and the
    ground truth with containers in them and under partial observation."""
    from robocog.server.app import build_server
    from robocog.server.config import SessionConfig

    config = SessionConfig(scene=Path("kitchen_plus"), data_dir=tmp_path / "memory")
    async with Client(build_server(config, profile="eval"), raise_exceptions=True) as client:
        tools = {t.name: t for t in (await client.list_tools()).tools}

        async def call(name: str, ok: bool, **arguments: Any) -> None:
            result = await client.call_tool(name, arguments)
            assert bool(result.is_error) != ok, (name, arguments, result.content)
            assert result.structured_content is not None, (name, arguments)
            assert validate_structured(tools[name].output_schema or {}, result.structured_content) == [], name

        await call("open", False, furniture="fridge")  # not at the fridge
        await call("move_to", True, location="Fridge")
        await call("open", True, furniture="fridge")
        await call("look_around", True)
        await call("open", True, furniture="fridge")  # already open: a success that moved nothing
        await call("close", True, furniture="fridge")
        await call("close", False, furniture="freezer")
        await call("reset_world", True, observe="room")
        await call("look_around", True)


# --- the pytest plugin ---------------------------------------------------------------------------


def test_the_plugin_is_registered_through_the_pytest11_entry_point() -> None:
    plugins = {ep.name: ep.value for ep in entry_points(group="pytest11")}
    assert plugins.get("robocog") == "robocog.server.testing"


async def test_a_client_author_can_run_a_task_and_assert_its_ground_truth(
    robocog_client: Client, robocog_world: RobocogWorld
) -> None:
    await robocog_world.reset(seed=0)
    await robocog_world.begin_task("T1")
    for action in T1_SEQUENCE:
        assert not (await robocog_client.call_tool(action[0], action_args(action))).is_error
    verdict = await robocog_world.assert_task("T1")
    assert verdict["success"] is True
    with pytest.raises(AssertionError, match="T2 failed"):
        await robocog_world.assert_task("T2")
    cube = next(o for o in (await robocog_world.state())["objects"] if o["object"] == "cube")
    assert (cube["location"], cube["position"]) == ("Kitchen Shelf", "top")


# --- the command against real servers ------------------------------------------------------------


def robocog(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    script = shutil.which("robocog", path=str(Path(sys.executable).parent))
    command = [script] if script else [sys.executable, "-m", "robocog.agent.cli"]
    env = {**os.environ, "ANONYMIZED_TELEMETRY": "False"}
    return subprocess.run([*command, *args], capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


@pytest.fixture
def http_url(tmp_path: Path) -> Iterator[str]:
    """`robocog-server --transport http` in the default profile, on a free port."""
    with http_server(tmp_path / "server.log", "--data-dir", str(tmp_path / "memory")) as url:
        yield url


async def test_check_against_a_spawned_stdio_server_names_a_newly_required_argument_breaking(
    robocog_client: Client, tmp_path: Path
) -> None:
    baseline = await dump_contract(robocog_client)  # the eval profile, as the spawned server has it
    tool(baseline, "move_to")["inputSchema"]["required"] = []
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(baseline), encoding="utf-8")
    done = robocog("contract", "check", str(path), "--profile", "eval", "--exercise", cwd=tmp_path)
    assert done.returncode == EXIT_BREAKING, done.stdout + done.stderr
    assert "BREAKING    tool move_to: argument 'location' newly required" in done.stdout
    assert "ok          tool look_around: exercised: result conforms to its outputSchema" in done.stdout
    assert "BREAKING: 1 breaking, 0 compatible" in done.stdout


def test_check_and_dump_over_http_list_a_new_tool_as_compatible(http_url: str, tmp_path: Path) -> None:
    dumped = robocog("contract", "dump", "--url", http_url, cwd=tmp_path)
    assert dumped.returncode == EXIT_OK, dumped.stderr
    baseline = json.loads(dumped.stdout)
    assert {t["name"] for t in baseline["tools"]} == {t["name"] for t in load("default")["tools"]}
    baseline["tools"] = [t for t in baseline["tools"] if t["name"] != "search_memory"]
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(baseline), encoding="utf-8")
    done = robocog("contract", "check", str(path), "--url", http_url, "--exercise", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stdout + done.stderr
    assert "compatible  tool search_memory: added" in done.stdout
    assert "compatible: 0 breaking, 1 compatible" in done.stdout


def test_check_exits_2_when_it_cannot_connect(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from robocog.agent.cli.main import main

    baseline = str(shipped_contract_path("default"))
    assert main(["contract", "check", baseline, "--url", f"http://127.0.0.1:{free_port()}/mcp"]) == EXIT_UNREACHABLE
    assert "could not connect" in capsys.readouterr().err
    assert main(["contract", "check", baseline, "--server-cmd", f"{sys.executable} -c pass"]) == EXIT_UNREACHABLE
    assert "could not connect" in capsys.readouterr().err
    assert main(["contract", "check", str(tmp_path / "missing.json")]) == EXIT_UNREACHABLE
    assert "cannot read the baseline" in capsys.readouterr().err
