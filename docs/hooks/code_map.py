"""MkDocs hook: the map of the code and its import rules, written from the tree at build time.

`<!-- code-map -->` becomes, for each package (server/, agent/, shared/, integrations/inspect/),
every module with the first sentence of its docstring, read with `ast` (nothing is imported);
`<!-- import-contracts -->` becomes the import contracts of pyproject.toml's [tool.importlinter],
which `make lint` checks. So the map cannot go stale as modules move.
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path
from typing import Any

CODE_MAP = "<!-- code-map -->"
CONTRACTS = "<!-- import-contracts -->"
ROOTS = ("server", "agent", "shared", "integrations/inspect")


def summary(path: Path) -> str:
    """The first sentence (or line) of a module's docstring, on one line; empty without one."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    first = " ".join(doc.split("\n\n", 1)[0].split())
    cut = first.find(". ")
    return (first[: cut + 1] if cut > 0 else first).replace("|", "\\|")


def code_map(root: Path) -> str:
    """A table per top-level folder: each module (a package by its __init__.py) and its summary."""
    lines: list[str] = []
    for top in ROOTS:
        base = root / top
        lines += [f"### `{top}/`", "", "| module | what it holds |", "|---|---|"]
        for path in sorted(base.rglob("*.py"), key=lambda p: p.relative_to(base).parts):
            if "__pycache__" in path.parts:
                continue
            rel = path.relative_to(root).as_posix()
            if path.name == "__init__.py":
                rel = path.parent.relative_to(root).as_posix() + "/"
            lines.append(f"| `{rel}` | {summary(path)} |")
        lines.append("")
    return "\n".join(lines)


def import_contracts(root: Path) -> str:
    """The import-linter contracts of pyproject.toml as a list: name, kind and the modules."""
    with open(root / "pyproject.toml", "rb") as f:
        config: dict[str, Any] = tomllib.load(f).get("tool", {}).get("importlinter", {})
    lines: list[str] = []
    for contract in config.get("contracts", []):
        kind = contract.get("type", "")
        lines.append(f"- **{contract.get('name', contract.get('id', ''))}** ({kind})")
        if kind == "layers":
            lines.append("  " + " → ".join(f"`{layer}`" for layer in contract.get("layers", [])))
        elif kind == "forbidden":
            sources = ", ".join(f"`{m}`" for m in contract.get("source_modules", []))
            forbidden = ", ".join(f"`{m}`" for m in contract.get("forbidden_modules", []))
            lines.append(f"  {sources} must not import {forbidden}")
    return "\n".join(lines) if lines else "No contracts are declared in pyproject.toml."


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """MkDocs' hook: replace the markers with the map and the contracts."""
    root = Path(config["config_file_path"]).resolve().parent
    if CODE_MAP in markdown:
        markdown = markdown.replace(CODE_MAP, code_map(root))
    if CONTRACTS in markdown:
        markdown = markdown.replace(CONTRACTS, import_contracts(root))
    return markdown
