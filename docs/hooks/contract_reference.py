"""MkDocs hook: the tools' reference, written from the published MCP contract at build time.

A page holding the marker `<!-- contract-reference -->` gets, in its place, every tool (arguments,
result, annotations, the profiles that publish it), resource, resource template and prompt of
assets/contract/default.json and eval.json, so the reference cannot drift from what the server
publishes (a test holds the server to those files).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

MARKER = "<!-- contract-reference -->"
ANNOTATIONS = {
    "readOnlyHint": "read-only",
    "destructiveHint": "destructive",
    "idempotentHint": "idempotent",
    "openWorldHint": "open world",
}


def cell(text: object) -> str:
    """Text fit for one cell of a markdown table."""
    return str(text).replace("|", "\\|").replace("\n", " ").strip()


def schema_type(schema: dict[str, Any]) -> str:
    """A JSON schema's type in a few words: `string`, `integer (≥ 1, ≤ 20)`, `"a" | "b"`, `array of string`."""
    if "enum" in schema:
        return " | ".join(f"`{json.dumps(v)}`" for v in schema["enum"])
    if "const" in schema:
        return f"`{json.dumps(schema['const'])}`"
    for key in ("anyOf", "oneOf"):
        if key in schema:
            return " or ".join(schema_type(s) for s in schema[key])
    if "$ref" in schema:
        return str(schema["$ref"]).rsplit("/", 1)[-1]
    kind = str(schema.get("type", "any"))
    if kind == "array":
        return f"array of {schema_type(schema.get('items', {}))}"
    bounds = [
        f"{word} {schema[key]}"
        for key, word in (
            ("minimum", "≥"),
            ("maximum", "≤"),
            ("minLength", "length ≥"),
            ("maxLength", "length ≤"),
            ("maxItems", "items ≤"),
        )
        if key in schema
    ]
    return kind + (f" ({', '.join(bounds)})" if bounds else "")


def fields_table(schema: dict[str, Any], *, with_required: bool) -> list[str]:
    """A table of an object schema's properties (arguments or result fields)."""
    properties: dict[str, Any] = schema.get("properties", {})
    if not properties:
        return ["None."]
    required = set(schema.get("required", []))
    head = "| name | type | required | description |" if with_required else "| field | type | description |"
    rows = [head, "|---|---|---|---|" if with_required else "|---|---|---|"]
    for name, prop in properties.items():
        description = cell(prop.get("description", ""))
        if "default" in prop:
            description += f" (default: `{json.dumps(prop['default'])}`)"
        kind = cell(schema_type(prop))
        if with_required:
            rows.append(f"| `{name}` | {kind} | {'yes' if name in required else 'no'} | {description} |")
        else:
            rows.append(f"| `{name}` | {kind} | {description} |")
    return rows


def tool_section(tool: dict[str, Any], profiles: list[str]) -> list[str]:
    """One tool's reference: heading, title, profiles, annotations, description, arguments, result."""
    hints = tool.get("annotations", {})
    flags = [word for key, word in ANNOTATIONS.items() if hints.get(key)] or ["not read-only"]
    lines = [f"### `{tool['name']}`", ""]
    lines.append(f"**{tool.get('title', tool['name'])}** · profiles: {', '.join(profiles)} · {', '.join(flags)}")
    lines += ["", str(tool.get("description", "")).strip(), "", "**Arguments**", ""]
    lines += fields_table(tool.get("inputSchema", {}), with_required=True)
    output = tool.get("outputSchema")
    if output:
        lines += ["", f"**Result** (`{output.get('title', 'result')}`)", ""]
        lines += fields_table(output, with_required=False)
    return [*lines, ""]


def reference(root: Path) -> str:
    """The reference's markdown, from the contract files under root/assets/contract."""
    default = json.loads((root / "assets" / "contract" / "default.json").read_text(encoding="utf-8"))
    evaluation = json.loads((root / "assets" / "contract" / "eval.json").read_text(encoding="utf-8"))
    in_default = {t["name"] for t in default["tools"]}
    robot = [t for t in evaluation["tools"] if t["name"] in in_default]
    controls = [t for t in evaluation["tools"] if t["name"] not in in_default]
    lines = [
        f"Contract {default['contract']} of the server `{default['server']}`; capabilities: "
        + ", ".join(f"`{c}`" for c in default["capabilities"])
        + ".",
        "",
        "## Robot tools",
        "",
        "Published in every profile; a model is offered these.",
        "",
    ]
    for tool in sorted(robot, key=lambda t: str(t["name"])):
        lines += tool_section(tool, ["default", "eval"])
    lines += ["## Harness controls", "", "Published with `--profile eval` only; never offered to a model.", ""]
    for tool in sorted(controls, key=lambda t: str(t["name"])):
        lines += tool_section(tool, ["eval"])
    lines += ["## Resources", "", "| URI | name | type | description |", "|---|---|---|---|"]
    for res in default["resources"]:
        lines.append(
            f"| `{res['uri']}` | {cell(res.get('title', res['name']))} | {res.get('mimeType', '')} "
            f"| {cell(res.get('description', ''))} |"
        )
    lines += ["", "## Resource templates", "", "| URI template | name | description |", "|---|---|---|"]
    for tpl in default["resourceTemplates"]:
        lines.append(
            f"| `{tpl['uriTemplate']}` | {cell(tpl.get('title', tpl['name']))} | {cell(tpl.get('description', ''))} |"
        )
    lines += ["", "## Prompts", "", "| name | title | arguments | description |", "|---|---|---|---|"]
    for prompt in default["prompts"]:
        args = ", ".join(f"`{a['name']}`" for a in prompt.get("arguments", [])) or "none"
        lines.append(
            f"| `{prompt['name']}` | {cell(prompt.get('title', ''))} | {args} | {cell(prompt.get('description', ''))} |"
        )
    return "\n".join(lines) + "\n"


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """MkDocs' hook: replace the marker with the reference."""
    if MARKER not in markdown:
        return markdown
    root = Path(config["config_file_path"]).resolve().parent
    return markdown.replace(MARKER, reference(root))
