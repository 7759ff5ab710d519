"""Every read of a library's private name (`robocog.server.compat`, `robocog.agent.client.compat`)
finds what it reads in the installed MCP SDK, ChromaDB and LiteLLM: an upgrade that moves one fails
here, naming it, instead of silently turning a feature off behind a `getattr` default."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.server.connection import Connection
from mcp.server.mcpserver import Context, MCPServer

from robocog.agent.client import compat as client_compat
from robocog.server import compat as server_compat
from tests.chroma_server import chroma_server

pytestmark = pytest.mark.anyio


async def test_the_server_reads_the_sdks_low_level_server_connection_transport_and_listeners() -> None:
    from mcp.server.lowlevel import Server

    seen: dict[str, Any] = {}
    mcp = MCPServer("reads")

    @mcp.tool()
    def probe(ctx: Context[Any]) -> str:
        session = ctx.request_context.session
        seen.update(
            connection=server_compat.connection_of(session),
            kind=server_compat.transport_kind(session),
            listens=server_compat.anyone_listens(ctx),
        )
        return "ok"

    assert isinstance(server_compat.lowlevel(mcp), Server)
    assert any(isinstance(m, server_compat.otel_middleware()) for m in mcp.middleware)
    async with Client(mcp) as client:
        assert not (await client.call_tool("probe", {})).is_error
    assert isinstance(seen["connection"], Connection)
    assert seen["kind"] == "direct"  # the SDK's in-process client
    assert seen["listens"] is False  # nobody listens on subscriptions/listen


async def test_the_client_reads_a_sessions_validators(tmp_path: Path) -> None:
    from robocog.server.app import build_server
    from robocog.server.config import SessionConfig

    async with Client(build_server(SessionConfig(data_dir=tmp_path), profile="eval")) as client:
        found = client_compat.output_validators(client.session)
    assert found is not None, "mcp moved ClientSession._tool_output_validators or ._output_schema_validator"
    validators, compile_one = found
    assert isinstance(validators, dict) and callable(compile_one)
    assert compile_one("t", {"type": "object"}) is not None


def test_the_client_reads_litellms_hidden_parameters_and_callback_lists() -> None:
    from robocog.agent.client.model import configured_litellm

    litellm = configured_litellm()
    response = litellm.completion(model="openai/x", messages=[{"role": "user", "content": "hi"}], mock_response="hi")
    hidden = client_compat.hidden_params(response)
    assert hidden is not None, "litellm moved ModelResponse._hidden_params"
    assert "response_cost" in hidden, "litellm keeps a response's cost elsewhere than _hidden_params"
    for name in (*client_compat.PUBLIC_CALLBACK_LISTS, *client_compat.PRIVATE_CALLBACK_LISTS):
        assert isinstance(getattr(litellm, name), list), f"litellm moved {name}"


def test_closing_a_chroma_http_client_closes_the_pools_nobody_else_uses(tmp_path: Path) -> None:
    import chromadb

    with chroma_server(tmp_path / "chroma") as url:
        host, port = url.removeprefix("http://").split(":")
        client = chromadb.HttpClient(host=host, port=int(port))
        client.heartbeat()
        pools = [client._server._session, client._admin_client._server._session]  # type: ignore[attr-defined]
        server_compat.close_chroma_pools(client)
    assert all(pool.is_closed for pool in pools)
