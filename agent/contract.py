"""`robocog contract`: the published MCP contract, dumped from a live server and checked against a baseline.

The contract is the canonical JSON of what a client can depend on: `tools/list`, `resources/list`,
`resources/templates/list` and `prompts/list`, each sorted by its key, plus the contract version the
server announces in its instructions ("MCP contract X.Y"). robocog ships its own in
`robocog.assets.contract` (`default.json`, `eval.json`; CHANGELOG.md lists the versions).

Everything here speaks the protocol only, so `dump`, `check` and `--exercise` work against any MCP
server: a server without resources or prompts simply has empty lists.

`check` classifies every difference between a baseline and the live server:

- breaking: a tool, resource, template or prompt removed (a rename reads as removed + added); a new
  required argument or an optional one made required; an argument removed, its type narrowed, an
  enum value removed or a bound tightened; an output field removed, made optional or retyped (its
  type widened, an enum value added); an annotation weakened (readOnlyHint or idempotentHint true →
  false, destructiveHint or openWorldHint false → true); a resource's MIME type changed; a prompt
  argument newly required or removed.
- compatible: anything added (tools, resources, templates, prompts, optional arguments, output
  fields), a widened argument type or enum, a relaxed bound, an output type narrowed, an annotation
  strengthened, titles, descriptions and defaults.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Literal, TextIO, cast

from robocog.shared.errors import ServerConnectionError

if TYPE_CHECKING:  # `robocog --help` builds this parser: the MCP SDK is imported only to connect
    from mcp import Client

#: The contract version in a server's instructions: "MCP contract 1.0", "contract 2.3".
VERSION_PATTERN = re.compile(r"\bcontract\s+v?(\d+(?:\.\d+)+)\b", re.IGNORECASE)

#: Sections of a contract and the key that names an entry in each.
SECTIONS: dict[str, str] = {"tools": "name", "resources": "uri", "resourceTemplates": "uriTemplate", "prompts": "name"}

Kind = Literal["breaking", "compatible", "ok"]

#: Exit codes of `robocog contract check`.
EXIT_OK, EXIT_BREAKING, EXIT_UNREACHABLE = 0, 1, 2


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

    from robocog.agent.connection import default_server_command

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

    from robocog.agent.connection import leaf_message

    log: IO[str] | None = None
    if target.url:
        transport: Any = target.url
    else:
        env = {"ANONYMIZED_TELEMETRY": "False", **{k: v for k, v in os.environ.items() if k.startswith("ROBOCOG_")}}
        command, *args = target.command
        log = tempfile.NamedTemporaryFile("w+", prefix="robocog-contract-", suffix=".log", delete=False)  # noqa: SIM115
        transport = stdio_client(StdioServerParameters(command=command, args=args, env=env), errlog=cast(TextIO, log))
    entered = False
    try:
        async with Client(transport) as client:
            entered = True
            yield client
    except Exception as exc:
        if entered:
            raise
        where = ""
        if log is not None:
            log.flush()
            tail = "\n".join(Path(log.name).read_text(encoding="utf-8", errors="replace").splitlines()[-10:])
            where = f"; the end of its log:\n{tail}" if tail.strip() else ""
        raise ServerConnectionError(f"could not connect to `{target.label}`: {leaf_message(exc)}{where}") from exc
    finally:
        if log is not None:
            log.close()
            Path(log.name).unlink(missing_ok=True)


# --- comparison ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Change:
    """One difference between a baseline and the live contract."""

    kind: Kind
    where: str  # e.g. "tool move_to", "prompt T1"
    what: str

    def line(self) -> str:
        return f"{self.kind.upper() if self.kind == 'breaking' else self.kind:<10}  {self.where}: {self.what}"


class _Schema:
    """A JSON Schema with its root, for resolving local `$ref`s."""

    def __init__(self, schema: Any, root: Any) -> None:
        self.root = root
        self.schema = self._resolve(schema)

    def _resolve(self, schema: Any, depth: int = 0) -> dict[str, Any]:
        if not isinstance(schema, dict):
            return {}
        ref = schema.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/") and depth < 32:
            node: Any = self.root
            for part in ref[2:].split("/"):
                node = node.get(part.replace("~1", "/").replace("~0", "~")) if isinstance(node, dict) else None
            merged = {**(node if isinstance(node, dict) else {}), **{k: v for k, v in schema.items() if k != "$ref"}}
            return self._resolve(merged, depth + 1)
        return schema

    def sub(self, schema: Any) -> _Schema:
        return _Schema(schema, self.root)

    def branches(self) -> list[_Schema]:
        """The alternatives of an anyOf/oneOf, else the schema itself."""
        alternatives = self.schema.get("anyOf") or self.schema.get("oneOf")
        if isinstance(alternatives, list) and alternatives:
            return [b for alt in alternatives for b in self.sub(alt).branches()]
        return [self]

    def types(self) -> set[str] | None:
        """The JSON types a value may have; None for any."""
        found: set[str] = set()
        for branch in self.branches():
            s = branch.schema
            if "const" in s:
                found.add(_json_type(s["const"]))
            elif isinstance(s.get("type"), str):
                found.add(s["type"])
            elif isinstance(s.get("type"), list):
                found.update(str(t) for t in s["type"])
            elif isinstance(s.get("enum"), list):
                found.update(_json_type(v) for v in s["enum"])
            else:
                return None
        return found

    def enum(self) -> set[str] | None:
        """The allowed values (as JSON text), when every alternative lists them (null aside); else None."""
        values: set[str] = set()
        for branch in self.branches():
            s = branch.schema
            if "const" in s:
                values.add(json.dumps(s["const"], sort_keys=True))
            elif isinstance(s.get("enum"), list):
                values.update(json.dumps(v, sort_keys=True) for v in s["enum"])
            elif s.get("type") == "null":
                values.add("null")
            else:
                return None
        return values

    def non_null(self) -> _Schema | None:
        """The one alternative that is not null (the value of an optional argument), if there is one."""
        values = [b for b in self.branches() if b.schema.get("type") != "null"]
        return values[0] if len(values) == 1 else None

    def object_branch(self) -> _Schema | None:
        """The one object alternative (models, optional models), if there is exactly one."""
        objects = [b for b in self.branches() if b.schema.get("type") == "object" or "properties" in b.schema]
        return objects[0] if len(objects) == 1 else None

    def array_items(self) -> _Schema | None:
        arrays = [
            b for b in self.branches() if b.schema.get("type") == "array" and isinstance(b.schema.get("items"), dict)
        ]
        return self.sub(arrays[0].schema["items"]) if len(arrays) == 1 else None


def _json_type(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "string"
    return "array" if isinstance(value, list) else "object"


def _widens(narrow: set[str], wide: set[str]) -> bool:
    """Every value of `narrow` types is a value of `wide` types (an integer is a number)."""
    return all(t in wide or (t == "integer" and "number" in wide) for t in narrow)


def _show(types: set[str] | None) -> str:
    return "any" if types is None else " | ".join(sorted(types)) or "nothing"


_LOWER_BOUNDS = ("minimum", "exclusiveMinimum", "minLength", "minItems")
_UPPER_BOUNDS = ("maximum", "exclusiveMaximum", "maxLength", "maxItems")


def _compare_value(
    old: _Schema, new: _Schema, where: str, path: str, direction: Literal["input", "output"], out: list[Change]
) -> None:
    """Compare one value's schema; input is contravariant (the server must accept at least as much)."""
    label = f"{'argument' if direction == 'input' else 'output field'} {path!r}" if path else direction
    old_types, new_types = old.types(), new.types()
    if old_types != new_types:
        # input: the new schema must accept what the old accepted; output: the new must produce only old types.
        if direction == "input":
            accepts = new_types is None or (old_types is not None and _widens(old_types, new_types))
        else:
            accepts = old_types is None or (new_types is not None and _widens(new_types, old_types))
        kind: Kind = "compatible" if accepts else "breaking"
        # input: widening accepts more; output: narrowing produces less; anything else breaks clients.
        verb = {("input", True): "widened", ("input", False): "narrowed", ("output", True): "narrowed"}.get(
            (direction, accepts), "retyped"
        )
        out.append(Change(kind, where, f"{label} {verb}: {_show(old_types)} → {_show(new_types)}"))
    old_enum, new_enum = old.enum(), new.enum()
    if old_enum is not None or new_enum is not None:
        removed = (old_enum or set()) - (new_enum or set()) if new_enum is not None else set()
        added = (new_enum or set()) - (old_enum or set()) if old_enum is not None else set()
        if removed:
            out.append(
                Change(
                    "breaking" if direction == "input" else "compatible",
                    where,
                    f"{label}: value(s) {', '.join(sorted(removed))} no longer "
                    f"{'accepted' if direction == 'input' else 'produced'}",
                )
            )
        if added:
            out.append(
                Change(
                    "compatible" if direction == "input" else "breaking",
                    where,
                    f"{label}: new value(s) {', '.join(sorted(added))}",
                )
            )
    old_value, new_value = old.non_null(), new.non_null()
    if direction == "input" and old_value is not None and new_value is not None:
        for bound in (*_LOWER_BOUNDS, *_UPPER_BOUNDS):
            a, b = old_value.schema.get(bound), new_value.schema.get(bound)
            if a == b or not all(isinstance(x, int | float | type(None)) for x in (a, b)):
                continue
            lower = bound in _LOWER_BOUNDS
            tighter = b is not None and (a is None or (b > a if lower else b < a))
            out.append(Change("breaking" if tighter else "compatible", where, f"{label}: {bound} {a} → {b}"))
        old_pattern, new_pattern = old_value.schema.get("pattern"), new_value.schema.get("pattern")
        if old_pattern != new_pattern:
            kind = "breaking" if new_pattern else "compatible"
            out.append(Change(kind, where, f"{label}: pattern {old_pattern!r} → {new_pattern!r}"))
    old_object, new_object = old.object_branch(), new.object_branch()
    if old_object is not None and new_object is not None:
        _compare_object(old_object, new_object, where, path, direction, out)
    old_items, new_items = old.array_items(), new.array_items()
    if old_items is not None and new_items is not None:
        _compare_value(old_items, new_items, where, f"{path}[]", direction, out)


def _compare_object(
    old: _Schema, new: _Schema, where: str, path: str, direction: Literal["input", "output"], out: list[Change]
) -> None:
    old_props: dict[str, Any] = old.schema.get("properties") or {}
    new_props: dict[str, Any] = new.schema.get("properties") or {}
    old_required = set(old.schema.get("required") or [])
    new_required = set(new.schema.get("required") or [])
    noun = "argument" if direction == "input" else "output field"
    for name in sorted(old_props.keys() | new_props.keys()):
        field = f"{path}.{name}" if path else name
        if name not in new_props:
            out.append(Change("breaking", where, f"{noun} {field!r} removed"))
        elif name not in old_props:
            if direction == "input":
                required = name in new_required
                what = f"new {'required' if required else 'optional'} argument {field!r}"
                out.append(Change("breaking" if required else "compatible", where, what))
            else:
                out.append(Change("compatible", where, f"new output field {field!r}"))
        else:
            was, now = name in old_required, name in new_required
            if was != now:
                if direction == "input":
                    kind: Kind = "breaking" if now else "compatible"
                    what = f"argument {field!r} {'newly required' if now else 'now optional'}"
                else:
                    kind = "compatible" if now else "breaking"
                    what = f"output field {field!r} {'now always present' if now else 'no longer always present'}"
                out.append(Change(kind, where, what))
            _compare_value(old.sub(old_props[name]), new.sub(new_props[name]), where, field, direction, out)
            for key in ("description", "title", "default"):
                a, b = old.sub(old_props[name]).schema.get(key), new.sub(new_props[name]).schema.get(key)
                if a != b:
                    out.append(Change("compatible", where, f"{noun} {field!r}: {key} changed"))


#: Annotation hints, their default (the spec's) and the value that promises more to a client.
_HINTS = {
    "readOnlyHint": (False, True),
    "destructiveHint": (True, False),
    "idempotentHint": (False, True),
    "openWorldHint": (True, False),
}


def _compare_tool(old: dict[str, Any], new: dict[str, Any], out: list[Change]) -> None:
    where = f"tool {old['name']}"
    for key in ("title", "description"):
        if old.get(key) != new.get(key):
            out.append(Change("compatible", where, f"{key} changed"))
    old_in = old.get("inputSchema") or {}
    new_in = new.get("inputSchema") or {}
    _compare_object(_Schema(old_in, old_in), _Schema(new_in, new_in), where, "", "input", out)
    old_out, new_out = old.get("outputSchema"), new.get("outputSchema")
    if old_out and not new_out:
        out.append(Change("breaking", where, "output schema removed (no more structured content promised)"))
    elif new_out and not old_out:
        out.append(Change("compatible", where, "output schema added"))
    elif old_out and new_out:
        _compare_value(_Schema(old_out, old_out), _Schema(new_out, new_out), where, "", "output", out)
    old_ann, new_ann = old.get("annotations") or {}, new.get("annotations") or {}
    for hint, (default, promise) in _HINTS.items():
        a, b = old_ann.get(hint, default), new_ann.get(hint, default)
        if a != b:
            weakened = a == promise
            out.append(Change("breaking" if weakened else "compatible", where, f"annotation {hint} {a} → {b}"))
    if old_ann.get("title") != new_ann.get("title"):
        out.append(Change("compatible", where, "annotation title changed"))


def _compare_prompt(old: dict[str, Any], new: dict[str, Any], out: list[Change]) -> None:
    where = f"prompt {old['name']}"
    for key in ("title", "description"):
        if old.get(key) != new.get(key):
            out.append(Change("compatible", where, f"{key} changed"))
    old_args = {a["name"]: a for a in old.get("arguments") or []}
    new_args = {a["name"]: a for a in new.get("arguments") or []}
    for name in sorted(old_args.keys() | new_args.keys()):
        if name not in new_args:
            out.append(Change("breaking", where, f"argument {name!r} removed"))
            continue
        now = bool(new_args[name].get("required"))
        if name not in old_args:
            what = f"new {'required' if now else 'optional'} argument {name!r}"
            out.append(Change("breaking" if now else "compatible", where, what))
            continue
        was = bool(old_args[name].get("required"))
        if was != now:
            what = f"argument {name!r} {'newly required' if now else 'now optional'}"
            out.append(Change("breaking" if now else "compatible", where, what))
        if old_args[name].get("description") != new_args[name].get("description"):
            out.append(Change("compatible", where, f"argument {name!r}: description changed"))


def _compare_resource(section: str, old: dict[str, Any], new: dict[str, Any], out: list[Change]) -> None:
    key = SECTIONS[section]
    where = f"{'resource template' if section == 'resourceTemplates' else 'resource'} {old[key]}"
    if old.get("mimeType") != new.get("mimeType"):
        out.append(Change("breaking", where, f"MIME type {old.get('mimeType')} → {new.get('mimeType')}"))
    for field in ("name", "title", "description", "annotations", "size"):
        if old.get(field) != new.get(field):
            out.append(Change("compatible", where, f"{field} changed"))


_SINGULAR = {"tools": "tool", "resources": "resource", "resourceTemplates": "resource template", "prompts": "prompt"}


def compare_contracts(baseline: dict[str, Any], live: dict[str, Any]) -> list[Change]:
    """Every difference from `baseline` to `live`, classified; breaking ones first."""
    out: list[Change] = []
    if baseline.get("contract") != live.get("contract"):
        out.append(Change("compatible", "contract", f"version {baseline.get('contract')} → {live.get('contract')}"))
    for section, key in SECTIONS.items():
        old = {entry[key]: entry for entry in baseline.get(section) or []}
        new = {entry[key]: entry for entry in live.get(section) or []}
        for name in sorted(old.keys() | new.keys()):
            where = f"{_SINGULAR[section]} {name}"
            if name not in new:
                out.append(Change("breaking", where, "removed (or renamed)"))
            elif name not in old:
                out.append(Change("compatible", where, "added"))
            elif section == "tools":
                _compare_tool(old[name], new[name], out)
            elif section == "prompts":
                _compare_prompt(old[name], new[name], out)
            else:
                _compare_resource(section, old[name], new[name], out)
    return sorted(out, key=lambda c: c.kind != "breaking")  # stable: each kind in the order found


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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """`robocog contract dump | check BASELINE.json`, with the server options."""
    sub = parser.add_subparsers(dest="contract_command", required=True)
    dump = sub.add_parser("dump", help="print the live server's canonical contract (JSON)")
    check = sub.add_parser(
        "check",
        help="compare the live server with a baseline contract: exit 0 compatible, 1 breaking, 2 unreachable",
    )
    check.add_argument("baseline", type=Path, help="a contract file, e.g. assets/contract/default.json")
    check.add_argument(
        "--exercise",
        action="store_true",
        help="also call each read-only tool that needs no arguments and validate its result against its outputSchema",
    )
    check.add_argument("--quiet", action="store_true", help="print only the breaking changes and the summary")
    for p in (dump, check):
        g = p.add_argument_group("server (any MCP server; default: a spawned robocog-server)")
        g.add_argument("--url", help="a running server over streamable HTTP, e.g. http://127.0.0.1:8765/mcp")
        g.add_argument("--server-cmd", help="command line that starts the server over stdio")
        g.add_argument(
            "--profile",
            choices=("default", "eval"),
            default=None,
            help="profile of the spawned robocog-server (default: default; for check, the baseline's file name "
            "when it is eval.json)",
        )
        g.add_argument("--data-dir", help="memory directory of the spawned robocog-server (default: a temporary one)")


async def _live(target: Target, exercise_tools: bool) -> tuple[dict[str, Any], list[Change]]:
    async with open_client(target) as client:
        try:
            contract = await dump_contract(client)
            notes = await exercise(client, contract) if exercise_tools else []
        except Exception as exc:
            raise ServerConnectionError(f"`{target.label}` failed while listing: {exc}") from exc
    return contract, notes


def main(args: argparse.Namespace) -> int:
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
            from robocog.agent.connection import leaf_message

            print(f"robocog contract: `{target.label}` failed: {leaf_message(exc)}", file=sys.stderr)
            return EXIT_UNREACHABLE
    if baseline is None:
        sys.stdout.write(contract_text(live))
        return EXIT_OK
    changes = compare_contracts(baseline, live) + notes
    return report(changes, str(args.baseline), target.label, quiet=args.quiet)


def report(changes: list[Change], baseline: str, live: str, *, quiet: bool = False) -> int:
    """Print the diff and the summary; the exit code (1 when anything is breaking)."""
    breaking = [c for c in changes if c.kind == "breaking"]
    compatible = [c for c in changes if c.kind == "compatible"]
    print(f"baseline: {baseline}\nlive:     {live}")
    for change in changes:
        if not quiet or change.kind == "breaking":
            print(f"  {change.line()}")
    verdict = "BREAKING" if breaking else "compatible"
    print(f"{verdict}: {len(breaking)} breaking, {len(compatible)} compatible difference(s)")
    return EXIT_BREAKING if breaking else EXIT_OK
