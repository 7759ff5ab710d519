"""Hostile values for attacking the tools: texts that have broken parsers somewhere, pieces repeated
into long texts, made-up tool names, extreme numbers, deep nesting. The fuzz test
(tests/integration/test_fuzz.py) draws from them with Hypothesis, the stdio fuzz (tests/bench/fuzz.py)
with `random`."""

from __future__ import annotations

from typing import Any

#: Texts that have broken parsers, tokenizers, databases and templates somewhere.
ODD_TEXTS = (
    "",
    " ",
    "\x00",
    "\t\r\n",
    "\x1b[2J",
    "null",
    "None",
    "NaN",
    "-1",
    "\ufeffmug",
    "mug\x00",
    "KITCHEN SHELF",
    " Kitchen Shelf\t",
    "kitchen_shelf",
    "\u202eflehS nehctiK",
    "🤖🧊☕",
    "𝕂𝕚𝕥𝕔𝕙𝕖𝕟",
    "\ud800",
    "a\udfffb",
    "' OR '1'='1' --",
    '"}]}\n{"jsonrpc":"2.0"',
    "<script>alert(1)</script>",
    "{{7*7}}${jndi:ldap://x}%s%n",
    "../../../../etc/passwd",
    "robocog://world/state",
)
#: Pieces repeated into long texts, and the lengths (around the limits, and up to a few MB).
PIECES = ("x", "Kitchen Shelf ", "\x00", "é", "🤖", "\r\n", "\ud800", "the mug ")
SIZES = (129, 201, 2_001, 4_097, 65_536, 1 << 20, 3 << 20)
#: Tools that exist nowhere, and names that are almost right.
MADE_UP_TOOLS = ("", "nope", "Move_To", "move_to ", "look_around\x00", "tools/call", "__init__", "x" * 10_000, "🤖")
NUMBERS = (0, -1, 1, 20, 21, 2**31, 2**63, -(2**63) - 1, 10**30, -(10**30), 10**400)


def repeat(piece: str, size: int) -> str:
    """`piece` repeated to exactly `size` characters."""
    return (piece * (size // len(piece) + 1))[:size]


def nested(depth: int) -> Any:
    """A list nested `depth` deep."""
    value: Any = []
    for _ in range(depth):
        value = [value]
    return value
