"""How two MCP contracts differ: every difference from a baseline to the live contract, classified.

- breaking: a tool, resource, template, prompt or server capability removed (a rename reads as
  removed + added); a rule (`RULES`: a capability that binds how a client must behave) added or
  removed; a new required argument or an optional one made required; an argument removed,
  its type narrowed, an enum value removed or a bound tightened; an output field removed, made
  optional or retyped (its type widened, an enum value added); an annotation weakened (readOnlyHint
  or idempotentHint true → false, destructiveHint or openWorldHint false → true); a resource's MIME
  type changed; a prompt argument newly required or removed.
- compatible: anything added (tools, resources, templates, prompts, capabilities, optional
  arguments, output fields), a widened argument type or enum, a relaxed bound, an output type
  narrowed, an annotation strengthened, titles, descriptions and defaults.

`report` prints the classification and gives `robocog contract check`'s exit code.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal

#: Sections of a contract and the key that names an entry in each.
SECTIONS: dict[str, str] = {"tools": "name", "resources": "uri", "resourceTemplates": "uriTemplate", "prompts": "name"}

Kind = Literal["breaking", "compatible", "ok"]

#: Capabilities that publish a rule a client must follow, not a feature it may use: adding one breaks
#: the clients that did otherwise, and so does dropping it (clients that follow it now meet a server
#: that does not). Each maps to what it binds, for the checker's line.
RULES: dict[str, str] = {
    "experimental.robocog/driver.issued": (
        "a client without a session drives with the id the server issues, never with a name it gives itself"
    ),
    "experimental.robocog/driver.handle": (
        "a client without a session passes the robot handle the server minted as the robot_id argument; on a "
        "fleet, a call that acts without one is refused and takes no robot"
    ),
}

#: Exit codes of `robocog contract check`.
EXIT_OK, EXIT_BREAKING, EXIT_UNREACHABLE = 0, 1, 2


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
    old_capabilities, new_capabilities = set(baseline.get("capabilities") or []), set(live.get("capabilities") or [])
    for name in sorted(old_capabilities ^ new_capabilities):
        removed = name in old_capabilities
        what = "removed" if removed else "added"
        if name in RULES:
            out.append(Change("breaking", f"capability {name}", f"rule {what}: {RULES[name]}"))
        else:
            out.append(Change("breaking" if removed else "compatible", f"capability {name}", what))
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
