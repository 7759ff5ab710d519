"""`robocog contract`: the published MCP contract, dumped from a live server and checked against a baseline.

The contract is the canonical JSON of what a client can depend on: the server's declared
capabilities, `tools/list`, `resources/list`, `resources/templates/list` and `prompts/list`, each
sorted by its key, plus the contract version the server announces in its instructions ("MCP
contract X.Y"). robocog ships its own in `robocog.assets.contract` (`default.json`, `eval.json`;
CHANGELOG.md lists the versions).

Everything here speaks the protocol only, so `dump`, `check` and `--exercise` work against any MCP
server: a server without resources or prompts simply has empty lists.

`check` classifies every difference between a baseline and the live server
(`robocog.agent.contract.diff`: what is breaking, what compatible).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, cast

from robocog.agent.contract.diff import EXIT_OK, EXIT_UNREACHABLE, SECTIONS, Change, compare_contracts, report
from robocog.shared.errors import ServerConnectionError
from robocog.shared.protocol import CONTRACT_VERSION_PATTERN

if TYPE_CHECKING:  # `robocog --help` builds this parser: the MCP SDK is imported only to connect
    from mcp import Client

#: The contract version in a server's instructions: "MCP contract 1.0", "contract 2.3".
VERSION_PATTERN = CONTRACT_VERSION_PATTERN


def shipped_contract_path(profile: str = "default") -> Path:
    """The contract robocog publishes for `profile` (inside the installed package)."""
    from robocog.assets import ASSETS_DIR

    return ASSETS_DIR / "contract" / f"{profile}.json"


# --- dump ----------------------------------------------------------------------------------------


def _dump(items: list[Any]) -> list[dict[str, Any]]:
    return [item.model_dump(mode="json", by_alias=True, exclude_none=True) for item in items]


async def _paged(fetch: Callable[[str | None], Awaitable[Any]], attribute: str) -> list[Any]:
    items: list[Any] = []
    cursor: str | None = None
    while True:
        page = await fetch(cursor)
        items.extend(getattr(page, attribute))
        cursor = page.next_cursor
        if not cursor:
            return items


def capability_names(declared: dict[str, Any], prefix: str = "") -> list[str]:
    """The declared capabilities as sorted dotted names: each capability present ("resources") and each
    sub-flag that is true or an object ("resources.subscribe", "prompts.listChanged"); false flags are absent."""
    names: list[str] = []
    for key, value in declared.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            names += [name, *capability_names(value, f"{name}.")]
        elif value is True:
            names.append(name)
    return sorted(names)


async def dump_contract(client: Client) -> dict[str, Any]:
    """The canonical contract of the server behind `client` (any MCP server)."""
    capabilities = client.server_capabilities
    tools: list[Any] = []
    resources: list[Any] = []
    templates: list[Any] = []
    prompts: list[Any] = []
    if capabilities.tools is not None:
        tools = await _paged(lambda c: client.list_tools(cursor=c, cache_mode="bypass"), "tools")
    if capabilities.resources is not None:
        resources = await _paged(lambda c: client.list_resources(cursor=c, cache_mode="bypass"), "resources")
        templates = await _paged(
            lambda c: client.list_resource_templates(cursor=c, cache_mode="bypass"), "resource_templates"
        )
    if capabilities.prompts is not None:
        prompts = await _paged(lambda c: client.list_prompts(cursor=c, cache_mode="bypass"), "prompts")
    found = VERSION_PATTERN.search(client.instructions or "")
    info = client.server_info
    contract: dict[str, Any] = {
        "capabilities": capability_names(capabilities.model_dump(mode="json", by_alias=True, exclude_none=True)),
        "contract": found.group(1) if found else None,
        "server": info.name if info is not None else None,
    }
    for section, values in (
        ("tools", tools),
        ("resources", resources),
        ("resourceTemplates", templates),
        ("prompts", prompts),
    ):
        entries = _dump(values)
        contract[section] = sorted(entries, key=lambda entry: str(entry.get(SECTIONS[section])))
    return contract


def contract_text(contract: dict[str, Any]) -> str:
    """The contract as its file holds it: indented, keys sorted, one trailing newline."""
    return json.dumps(contract, indent=2, sort_keys=True, ensure_ascii=False) + "\n"


# --- connection ----------------------------------------------------------------------------------


@dataclass
class Target:
    """A server to reach: `url` over streamable HTTP, else `command` spawned over stdio."""

    url: str | None
    command: list[str]

    @property
    def label(self) -> str:
        import shlex

        return self.url or shlex.join(self.command)


def default_target(url: str | None, server_cmd: str | None, profile: str | None, data_dir: str | None) -> Target:
    """`--url`, `--server-cmd` as given, or robocog-server in `profile` with a throwaway memory."""
    import shlex

    from robocog.agent.client.connection import default_server_command

    if url:
        return Target(url=url, command=[])
    if server_cmd:
        return Target(url=None, command=shlex.split(server_cmd))
    command = [*default_server_command(), "--profile", profile or "default"]
    if data_dir:
        command += ["--data-dir", data_dir]
    return Target(url=None, command=command)


@asynccontextmanager
async def open_client(target: Target) -> AsyncIterator[Client]:
    """A connected client; anything that stops the connection becomes a `ServerConnectionError`."""
    from mcp import Client
    from mcp.client.stdio import StdioServerParameters, stdio_client

    from robocog.agent.client.connection import ServerLog, leaf_message, spawn_env

    log: ServerLog | None = None
    if target.url:
        transport: Any = target.url
    else:
        command, *args = target.command
        log = ServerLog("robocog-contract-")
        params = StdioServerParameters(command=command, args=args, env=spawn_env())
        transport = stdio_client(params, errlog=cast(TextIO, log.file))
    entered = False
    try:
        async with Client(transport) as client:
            entered = True
            yield client
    except Exception as exc:
        if entered:
            raise
        tail = "" if log is None else log.tail(10)
        where = f"; the end of its log:\n{tail}" if tail.strip() else ""
        raise ServerConnectionError(f"could not connect to `{target.label}`: {leaf_message(exc)}{where}") from exc
    finally:
        if log is not None:
            log.close()


# --- exercise ------------------------------------------------------------------------------------


def validate_structured(schema: dict[str, Any], data: Any) -> list[str]:
    """Why `data` does not conform to the JSON Schema `schema` (empty when it does)."""
    from jsonschema import validators

    cls = validators.validator_for(schema)
    return [
        f"{'/'.join(str(p) for p in error.absolute_path) or '(root)'}: {error.message}"
        for error in sorted(cls(schema).iter_errors(data), key=lambda e: list(map(str, e.absolute_path)))
    ]


def exercisable(tool: dict[str, Any]) -> bool:
    """A tool `--exercise` may call: read-only, no required arguments."""
    annotations = tool.get("annotations") or {}
    return annotations.get("readOnlyHint") is True and not (tool.get("inputSchema") or {}).get("required")


async def exercise(client: Client, contract: dict[str, Any]) -> list[Change]:
    """Call each read-only tool without arguments; a result that breaks its outputSchema is breaking."""
    out: list[Change] = []
    for tool in contract["tools"]:
        if not exercisable(tool):
            continue
        where = f"tool {tool['name']}"
        try:
            result = await client.call_tool(tool["name"], {})
        except Exception as exc:  # a protocol error: the tool cannot be called as its contract says
            out.append(Change("breaking", where, f"exercised: the call raised {type(exc).__name__}: {exc}"))
            continue
        schema = tool.get("outputSchema")
        data = getattr(result, "structured_content", None)
        if getattr(result, "is_error", False) and data is None:
            text = " ".join(getattr(c, "text", "") for c in getattr(result, "content", []))
            out.append(Change("breaking", where, f"exercised: the call failed: {text[:200]}"))
        elif schema and data is None:
            out.append(
                Change("breaking", where, "exercised: no structured content, though an outputSchema is declared")
            )
        elif schema:
            problems = validate_structured(schema, data)
            for problem in problems[:5]:
                out.append(Change("breaking", where, f"exercised: result does not match outputSchema: {problem}"))
            if not problems:
                out.append(Change("ok", where, "exercised: result conforms to its outputSchema"))
    return out


# --- the command ---------------------------------------------------------------------------------


async def _live(target: Target, exercise_tools: bool) -> tuple[dict[str, Any], list[Change]]:
    async with open_client(target) as client:
        try:
            contract = await dump_contract(client)
            notes = await exercise(client, contract) if exercise_tools else []
        except Exception as exc:
            raise ServerConnectionError(f"`{target.label}` failed while listing: {exc}") from exc
    return contract, notes


def contract_command(args: argparse.Namespace) -> int:
    """Run `robocog contract …`; returns the exit code."""
    import anyio

    command: str = args.contract_command
    profile: str | None = args.profile
    if command == "check" and profile is None and args.baseline.stem == "eval":
        profile = "eval"
    baseline: dict[str, Any] | None = None
    if command == "check":
        try:
            baseline = json.loads(args.baseline.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            print(f"robocog contract: cannot read the baseline {args.baseline}: {exc}", file=sys.stderr)
            return EXIT_UNREACHABLE
    with tempfile.TemporaryDirectory(prefix="robocog-contract-") as scratch:
        target = default_target(args.url, args.server_cmd, profile, args.data_dir or str(Path(scratch) / "memory"))
        try:
            live, notes = anyio.run(_live, target, bool(getattr(args, "exercise", False)))
        except ServerConnectionError as exc:
            print(f"robocog contract: {exc}", file=sys.stderr)
            return EXIT_UNREACHABLE
        except (Exception, BaseExceptionGroup) as exc:  # the connection broke down while closing
            from robocog.agent.client.connection import leaf_message

            print(f"robocog contract: `{target.label}` failed: {leaf_message(exc)}", file=sys.stderr)
            return EXIT_UNREACHABLE
    if baseline is None:
        sys.stdout.write(contract_text(live))
        return EXIT_OK
    changes = compare_contracts(baseline, live) + notes
    return report(changes, str(args.baseline), target.label, quiet=args.quiet)
