"""How the client reads a model's slips (`robocog.agent.client.slips`): what it decodes, what it counts
as a tool call written as text, and what it leaves as prose. Over HTTP: tests/e2e/test_local_servers.py."""

from __future__ import annotations

import json

import pytest

from robocog.agent.client.slips import decode_arguments, text_tool_calls

TOOLS = ["look_around", "move_to", "grab", "place", "end_task", "add_to_scratchpad"]


@pytest.mark.parametrize(
    ("raw", "expected"),
    [
        ('{"object": "mug"}', ({"object": "mug"}, None, None)),
        ("", ({}, None, None)),
        (json.dumps(json.dumps({"object": "mug"})), ({"object": "mug"}, "double_encoded", None)),
        ('"mug"', (None, None, "must be a JSON object, not str")),
        (json.dumps("[1, 2]"), (None, None, "must be a JSON object, not str")),
        ("[1, 2]", (None, None, "must be a JSON object, not list")),
    ],
    ids=["object", "empty", "double-encoded", "string", "string-of-a-list", "list"],
)
def test_arguments_are_decoded_only_where_the_object_is_clear(raw: str, expected: tuple[object, ...]) -> None:
    assert decode_arguments(raw) == expected


def test_arguments_that_are_not_json_are_a_problem_named_for_the_model() -> None:
    arguments, slip, problem = decode_arguments('{"object": "mug"')
    assert (arguments, slip) == (None, None) and problem is not None and problem.startswith("are not a valid JSON")


@pytest.mark.parametrize(
    ("content", "count"),
    [
        ('<tool_call>{"name": "grab", "arguments": {"object": "mug"}}</tool_call>' * 3, 3),
        ('<tool_call>\n{"name": "grab", "arguments": {"object": "mug"}}', 1),  # cut before its end tag
        ('<function=move_to>{"location": "Kitchen Table"}</function>', 1),
        ("<function name='place' location='Kitchen Shelf' position='top'/>", 1),
        ("functions.add_to_scratchpad:\nplan: grab the mug", 1),
        ('[{"name": "look_around", "arguments": {}}, {"name": "grab", "arguments": {"object": "cube"}}]', 2),
        ('{"type": "function", "function": {"name": "end_task", "arguments": {"status": "success"}}}', 1),
        ('{"name": "fly", "arguments": {}}', 0),  # not a tool it was offered
        ("functions.fly: now", 0),
        ('I see {"mug": "Kitchen Table"}. Search_memory: shelf. End_task: success', 0),  # prose
        (None, 0),
    ],
    ids=[
        "hermes-x3",
        "hermes-unclosed",
        "function-equals",
        "function-name",
        "functions-dot",
        "json-list",
        "json-nested",
        "unknown-tool",
        "functions-unknown",
        "prose",
        "none",
    ],
)
def test_tool_calls_written_as_text_are_counted(content: str | None, count: int) -> None:
    assert text_tool_calls(content, TOOLS) == count
