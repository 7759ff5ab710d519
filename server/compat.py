"""Every read of a private name of a library the server is built on, in one place.

The MCP SDK (mcp 2.3) and ChromaDB (1.5) give no public way to a few things the server needs; each
read below names what it reads and why. `tests/integration/test_private_reads.py` runs every one of them
against the installed libraries' real objects and fails, naming the read, when an upgrade moves
what it finds: an upgrade can no longer break one silently behind a `getattr` default.

- mcp: `MCPServer._lowlevel_server`, to add request handlers (logging, subscriptions), wrap
  `get_capabilities` and run it over stdio on our own pipes;
- mcp: `session._connection`: a request's connection identifies its client (log level,
  subscriptions, who drives the robot);
- mcp: `session._request_outbound.transport.kind`: "direct" is the SDK's in-process client, trusted,
  which takes progress without a token;
- mcp: `Context._subscriptions` and `InMemorySubscriptionBus._listeners`: whether anyone listens for
  a published event;
- mcp: `mcp.server._otel.OpenTelemetryMiddleware`, taken off when nothing records spans;
- chromadb: `Client._admin_client`, `._identifier`, `._server._session` and
  `SharedSystemClient._identifier_to_system`: an HTTP client never closes its connection pools.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mcp.server.connection import Connection
    from mcp.server.lowlevel import Server
    from mcp.server.mcpserver import Context, MCPServer


def lowlevel(mcp: MCPServer[Any]) -> Server[Any]:
    """The SDK's low-level server inside `mcp`."""
    server: Server[Any] = mcp._lowlevel_server
    return server


def connection_of(session: Any) -> Connection:
    """The connection a request's session proxy (`ServerRequestContext.session`) came on."""
    connection: Connection = session._connection
    return connection


def transport_kind(session: Any) -> str | None:
    """The SDK's name of the transport a request's session came on: "streamable-http", "jsonrpc", or
    "direct" for its in-process client; None for a session that has no dispatch context."""
    outbound = getattr(session, "_request_outbound", None)  # a session built by hand (tests) has none
    kind = getattr(getattr(outbound, "transport", None), "kind", None)
    return kind if isinstance(kind, str) else None


def anyone_listens(ctx: Context[Any]) -> bool:
    """Whether a `subscriptions/listen` stream may hear an event published through `ctx`: the SDK's
    in-process bus with no listener hears nothing; any other bus (one across replicas, say) may."""
    from mcp.server.subscriptions import InMemorySubscriptionBus

    bus = ctx._subscriptions
    return not (isinstance(bus, InMemorySubscriptionBus) and not bus._listeners)


def otel_middleware() -> type:
    """The SDK's OpenTelemetry middleware class."""
    from mcp.server._otel import OpenTelemetryMiddleware

    return OpenTelemetryMiddleware


def close_chroma_pools(client: Any) -> None:
    """Close a Chroma HTTP client, then the connection pools (its own and its admin client's) that
    no one else uses once it is closed: Chroma's `close()` leaves them open."""
    from chromadb.api.shared_system_client import SharedSystemClient

    owners = [client, client._admin_client]
    pools = [(owner._identifier, owner._server._session) for owner in owners]
    client.close()
    for identifier, pool in pools:
        if identifier not in SharedSystemClient._identifier_to_system:
            pool.close()
