"""What the server keeps per connected client: its log level and its resource subscriptions.

MCP's logging and subscriptions, beside the tools. The server's own log records (loggers under
`robocog.server`) go to stderr from the server's --log-level up, as before, and, when a client asked
for them, to that client as `notifications/message` at the level it chose:

- a record logged while a call runs (episode begin and end, action failures, bad input) is
  collected for that call and sent to its caller when the call ends, on the call's own stream;
- a record logged at start-up (the scene, the memory backend, "robot ready") is kept and sent to
  every client that sets a level with `logging/setLevel`, once, whenever it does.

Which records a call or the start-up collects is decided by a context variable, so several
servers in one process never see each other's records, and worker threads (where the session
runs) inherit the collector of the call that started them.

A client that subscribes to a world resource (`resources/subscribe`) is sent
`notifications/resources/updated` after every action that changed the world. The SDK has no
per-connection state of its own for either feature on the handshake protocol versions, so this
module keeps it, keyed by the connection, and forgets it when the connection closes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any, get_args

from mcp.server.connection import Connection
from mcp.server.context import ServerRequestContext
from mcp_types import LOG_LEVEL_META_KEY, LoggingLevel, LoggingMessageNotification, LoggingMessageNotificationParams
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from robocog.server import compat
from robocog.server.config import NOTICE

#: The server's loggers (the agent's, in the same process, are left alone).
LOGGER = "robocog.server"
#: MCP's levels, least severe first (RFC 5424 order).
LEVELS: tuple[LoggingLevel, ...] = get_args(LoggingLevel)
#: The resources an action can change; map, tasks and the description of the tools never change.
WORLD_RESOURCES = ("robocog://world/state", "robocog://world/image", "robocog://world/description")
WORLD_TEMPLATES = ("robocog://objects/", "robocog://locations/")
#: At most this many start-up records are kept for clients that set a level later.
BACKLOG = 100


def mcp_level(levelno: int) -> LoggingLevel:
    """The MCP level of a Python log level."""
    if levelno >= logging.CRITICAL:
        return "critical"
    if levelno >= logging.ERROR:
        return "error"
    if levelno >= logging.WARNING:
        return "warning"
    if levelno >= NOTICE:
        return "notice"
    if levelno >= logging.INFO:
        return "info"
    return "debug"


def at_least(level: LoggingLevel, threshold: LoggingLevel) -> bool:
    return LEVELS.index(level) >= LEVELS.index(threshold)


@dataclass(frozen=True)
class LogEntry:
    """One record as MCP sends it."""

    level: LoggingLevel
    logger: str
    message: str

    @classmethod
    def of(cls, record: logging.LogRecord) -> LogEntry:
        return cls(mcp_level(record.levelno), record.name, record.getMessage())

    def notification(self) -> LoggingMessageNotification:
        # Sent as a plain notification: the SDK's logging helpers (`ctx.log`, `Connection.log`)
        # warn on every call, since MCP deprecates logging from 2026-07-28 on (SEP-2577); the
        # handshake versions that every desktop client speaks today still have it.
        return LoggingMessageNotification(
            params=LoggingMessageNotificationParams(level=self.level, logger=self.logger, data=self.message)
        )


#: Where robocog's records go besides stderr: the current call's list, or the start-up backlog.
_collector: ContextVar[Callable[[LogEntry], None] | None] = ContextVar("robocog_log_collector", default=None)


@contextmanager
def collecting(sink: Callable[[LogEntry], None] | None) -> Iterator[None]:
    """Inside this block (and the worker threads it starts), the server's records also go to `sink`
    (None: to no client, whatever an enclosing block collects)."""
    token = _collector.set(sink)
    try:
        yield
    finally:
        _collector.reset(token)


class _ToClients(logging.Handler):
    """Hands every record to the current collector, if there is one."""

    def emit(self, record: logging.LogRecord) -> None:
        sink = _collector.get()
        if sink is not None:
            sink(LogEntry.of(record))


class _ToStderr(logging.Handler):
    """Hands records at or above the server's --log-level to the root logger's handlers (stderr)."""

    def emit(self, record: logging.LogRecord) -> None:
        logging.getLogger().handle(record)


def install_log_handlers(stderr_level: str) -> None:
    """Let every server record reach the collectors, and stderr only from `stderr_level` up."""
    log = logging.getLogger(LOGGER)
    log.setLevel(logging.DEBUG)
    log.propagate = False
    for handler in [h for h in log.handlers if isinstance(h, _ToClients | _ToStderr)]:
        log.removeHandler(handler)
    log.addHandler(_ToClients())
    stderr = _ToStderr()
    stderr.setLevel(stderr_level)
    log.addHandler(stderr)


def connection_of(ctx: ServerRequestContext[Any, Any]) -> Connection:
    """The connection a request came on (what identifies a client)."""
    return compat.connection_of(ctx.session)


@dataclass(eq=False)
class Client:
    """One connected client: the level it chose (None: it never chose, nothing is sent), the
    resources it subscribed to, and how much of the start-up backlog it has been sent."""

    connection: Connection
    level: LoggingLevel | None = None
    subscriptions: set[str] = field(default_factory=set)
    backlog_sent: int = 0

    def wants(self, entry: LogEntry) -> bool:
        return self.level is not None and at_least(entry.level, self.level)


class Clients:
    """Every connected client's log level and subscriptions, and the start-up backlog."""

    def __init__(self) -> None:
        self._clients: dict[Connection, Client] = {}
        self.backlog: list[LogEntry] = []

    def of(self, ctx: ServerRequestContext[Any, Any]) -> Client:
        """The client of this request, registered on first sight and forgotten when it disconnects."""
        connection = connection_of(ctx)
        client = self._clients.get(connection)
        if client is None:
            client = self._clients[connection] = Client(connection)
            connection.exit_stack.callback(self._clients.pop, connection, None)
        return client

    def keep(self, entry: LogEntry) -> None:
        """A start-up record (called from any thread; list.append is atomic)."""
        if len(self.backlog) < BACKLOG:
            self.backlog.append(entry)

    async def set_level(self, ctx: ServerRequestContext[Any, Any], level: LoggingLevel) -> None:
        client = self.of(ctx)
        client.level = level
        await self._send_backlog(client)

    async def send_backlog(self) -> None:
        """Send the start-up records not yet sent to every client that chose a level."""
        for client in list(self._clients.values()):
            await self._send_backlog(client)

    async def _send_backlog(self, client: Client) -> None:
        entries, client.backlog_sent = self.backlog[client.backlog_sent :], len(self.backlog)
        for entry in entries:
            if client.wants(entry):
                params = entry.notification().params.model_dump(mode="json", by_alias=True, exclude_none=True)
                await client.connection.notify("notifications/message", params)

    def wants(self, ctx: ServerRequestContext[Any, Any], entry: LogEntry) -> bool:
        """Whether the client of `ctx` asked for records like `entry`: from 2026-07-28 on, each
        request carries its own level; before, `logging/setLevel` set one for the connection."""
        if ctx.protocol_version in MODERN_PROTOCOL_VERSIONS:
            level = (ctx.meta or {}).get(LOG_LEVEL_META_KEY)
            return level in LEVELS and at_least(entry.level, level)
        client = self._clients.get(connection_of(ctx))
        return client is not None and client.wants(entry)

    def listening(self, ctx: ServerRequestContext[Any, Any]) -> bool:
        """Whether the client of `ctx` asked for log records at all (else a call collects none)."""
        if ctx.protocol_version in MODERN_PROTOCOL_VERSIONS:
            return (ctx.meta or {}).get(LOG_LEVEL_META_KEY) in LEVELS
        client = self._clients.get(connection_of(ctx))
        return client is not None and client.level is not None

    async def send(self, ctx: ServerRequestContext[Any, Any], entries: list[LogEntry]) -> None:
        """A call's records to its caller, on the call's own stream, as far as it asked for them."""
        for entry in entries:
            if self.wants(ctx, entry):
                await ctx.session.send_notification(entry.notification(), related_request_id=ctx.request_id)

    def subscribe(self, ctx: ServerRequestContext[Any, Any], uri: str) -> None:
        """Any URI is accepted; only the world's resources are ever updated (see `world_changed`)."""
        self.of(ctx).subscriptions.add(uri)

    def unsubscribe(self, ctx: ServerRequestContext[Any, Any], uri: str) -> None:
        self.of(ctx).subscriptions.discard(uri)

    async def world_changed(self, only: Connection | None = None) -> None:
        """Tell every subscriber of a world resource (state, image, description, one object, one
        location) that it changed; with `only`, the subscribers on that connection (a fleet robot's
        driver: the other clients watch other worlds)."""
        for client in list(self._clients.values()):
            if only is not None and client.connection is not only:
                continue
            for uri in sorted(client.subscriptions):
                if uri in WORLD_RESOURCES or uri.startswith(WORLD_TEMPLATES):
                    await client.connection.send_resource_updated(uri)
