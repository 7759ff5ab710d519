"""The client interfaces the episode loop and the harness depend on, whichever client serves them.

`McpClient` is what they ask of an MCP client session: the official SDK's `mcp.Client` (every server a
user names, over stdio or streamable HTTP) and robocog's `lean.LeanClient` (the servers a study starts
itself) both are one, as mypy checks where `connection.connect` builds a `Robot` from either.
`Channel` is what the lean client asks of the connection under it: `lean.StdioChannel` (a worker's
server over stdio) and `json_http.JsonHttpLink` (a study's fleet over HTTP, with JSON answers).
"""

from __future__ import annotations

from typing import Any, Protocol

from mcp_types import CallToolResult, GetPromptResult, ListToolsResult, ReadResourceResult, RequestParamsMeta

#: A JSON-RPC message, as a channel carries it.
Message = dict[str, Any]


class McpClient(Protocol):
    """What robocog's harness asks of an MCP client: the SDK's `Client` or a `LeanClient`."""

    @property
    def instructions(self) -> str | None: ...

    async def list_tools(self) -> ListToolsResult: ...

    async def call_tool(
        self,
        name: str,
        arguments: dict[str, Any] | None = None,
        read_timeout_seconds: float | None = None,
        *,
        meta: RequestParamsMeta | None = None,
    ) -> CallToolResult: ...

    async def read_resource(self, uri: str) -> ReadResourceResult: ...

    async def get_prompt(self, name: str, arguments: dict[str, str] | None = None) -> GetPromptResult: ...


class Channel(Protocol):
    """One connection to a server (opened and closed by its owner): a request's JSON-RPC message in,
    its answer (a result or an error) out; a server that cannot be reached is the answer
    `CONNECTION_CLOSED`, naming why."""

    async def request(self, message: Message) -> Message: ...

    async def notify(self, message: Message) -> None: ...


__all__ = ["Channel", "McpClient", "Message"]
