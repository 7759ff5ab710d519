"""The client's output-schema validators: compiled once per process and schema, shared by sessions."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcp import Client

from robocog.agent.client import output_schemas
from robocog.agent.client.output_schemas import share_validators
from robocog.server.app import build_server
from robocog.server.config import SessionConfig

pytestmark = pytest.mark.anyio


async def test_a_second_session_reuses_the_first_ones_validators_and_still_validates(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(output_schemas, "_compiled", type(output_schemas._compiled)())
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"), profile="eval")
    async with Client(server) as first:
        tools = (await first.list_tools()).tools
        with_schema = [t for t in tools if t.output_schema]
        distinct = len({json.dumps(t.output_schema, sort_keys=True) for t in with_schema})
        assert distinct > 1 and share_validators(first.session, tools) == len(with_schema) - distinct
        mine = dict(first.session._tool_output_validators)
    async with Client(server) as second:
        assert share_validators(second.session, (await second.list_tools()).tools) == len(with_schema)
        theirs = second.session._tool_output_validators
        assert all(mine[t.name] is theirs[t.name] for t in with_schema)
        result = await second.call_tool("look_around", {})
        assert not result.is_error
        # the shared validator is the one the SDK checks results with: a result that breaks the schema fails
        look = theirs["look_around"]
        broken = dict(result.structured_content or {}, locations="not a list")
        assert next(look.iter_errors(broken), None) is not None
        assert next(look.iter_errors(result.structured_content), None) is None


def test_the_fast_check_answers_valid_results_and_the_sdk_reports_invalid_ones() -> None:
    from jsonschema import Draft202012Validator
    from referencing import Registry

    schema = {
        "type": "object",
        "properties": {"where": {"$ref": "#/$defs/Place"}, "mail": {"type": "string", "format": "email"}},
        "required": ["where"],
        "$defs": {"Place": {"type": "array", "items": {"type": "number"}, "minItems": 2}},
    }
    sdk = Draft202012Validator(schema, registry=Registry())
    checked = output_schemas.FastValidator.over(sdk, schema)
    assert isinstance(checked, output_schemas.FastValidator)
    valid: list[object] = [{"where": [1, 2]}, {"where": [1, 2], "mail": "not an address"}]  # formats: not asserted
    for instance in valid:
        assert list(checked.iter_errors(instance)) == list(sdk.iter_errors(instance)) == []
    invalid: list[object] = [{"where": [1]}, {"where": "kitchen"}, {}, []]
    for instance in invalid:
        messages = [e.message for e in sdk.iter_errors(instance)]
        assert [e.message for e in checked.iter_errors(instance)] == messages != []


def test_a_schema_that_refers_outside_itself_is_left_to_the_sdk_and_fetches_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    asked: list[str] = []

    def refuse(uri: str) -> object:  # jsonschema-rs would fetch the URI over the network without one
        asked.append(uri)
        return output_schemas._no_retrieval(uri)

    monkeypatch.setattr(output_schemas, "_no_retrieval", refuse)
    sdk = object()
    assert output_schemas.FastValidator.over(sdk, {"$ref": "https://example.com/schema.json"}) is sdk
    assert set(asked) == {"https://example.com/schema.json"}  # asked (it may ask again), never fetched
