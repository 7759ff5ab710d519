"""What the live viewer shows, as a stream of events: every tool call and its result, world snapshots.

The MCP tool handler (`app.py`, `register_tool`) hands each call to `EventBus.observe`, which
publishes a `call` event when it starts and a `result` event when it ends (the result's summary,
whether it is an error, how long it took, and for `end_task` and `check_task` the verdict). After a
call that may have changed the world, a background task reads a snapshot of the ground truth (one
read for any number of calls that finished meanwhile) and publishes it as a `state` event.

Bounded: the bus keeps the last `BACKLOG` events; a reader that falls further behind is told so
(a `gap` event) and catches up from the newest snapshot, so a slow browser costs the server no
memory. Cheap per reader: an event is encoded once for all readers, and a reader that keeps up
finds its new events from the newest end (the viewer caps the readers, `viewer.MAX_READERS`).
Camera images that `look` returned are kept for the last `IMAGES` calls only.

Everything here runs on the server's event loop (the viewer's web server shares it); nothing is
published from a worker thread.
"""

from __future__ import annotations

import base64
import json
import logging
import time
from collections import OrderedDict, deque
from collections.abc import AsyncGenerator, AsyncIterator, Awaitable, Callable, Mapping
from contextlib import aclosing
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import anyio
from mcp_types import CallToolResult, ImageContent, TextContent
from pydantic import BaseModel

from robocog.shared.perturbations import PERTURBATION_META_KEY
from robocog.shared.protocol import CONTROL_TOOLS

logger = logging.getLogger("robocog.server.viewer")

#: Events kept for readers that connect late or fall behind.
BACKLOG = 500
#: `look` images kept (PNG bytes), newest last.
IMAGES = 20
#: Longest text of an argument or a summary that an event carries (characters).
MAX_TEXT = 600
#: Largest structured result an event carries whole (characters of JSON); bigger ones are left out.
MAX_STRUCTURED = 6000
#: Tools whose result is a verdict on the episode.
VERDICT_TOOLS = frozenset({"end_task", "check_task"})
#: Tools that start a new episode (the viewer clears the path and the verdict).
EPISODE_TOOLS = frozenset({"reset_world", "begin_task"})

Snapshot = Callable[[], Awaitable[dict[str, Any]]]


@dataclass(frozen=True)
class Event:
    """One thing that happened: `seq` counts from 1 in the order of publication."""

    seq: int
    kind: str  # "call", "result", "state" or "gap"
    data: dict[str, Any]
    t: float = field(default_factory=time.time)

    def as_json(self) -> dict[str, Any]:
        return {"seq": self.seq, "kind": self.kind, "t": round(self.t, 3), **self.data}

    @cached_property
    def encoded(self) -> bytes:
        """The event as one server-sent event (its seq is the id a reconnecting browser resumes from),
        encoded once however many readers send it."""
        return (
            f"id: {self.seq}\nevent: {self.kind}\ndata: {json.dumps(self.as_json(), ensure_ascii=False)}\n\n".encode()
        )

    def sse(self) -> bytes:
        return self.encoded


def _short(value: Any) -> Any:
    """`value` with long strings cut to `MAX_TEXT` characters (for arguments), as JSON (an argument the
    SDK validated into a model, e.g. reset_world's perturbations, as its JSON)."""
    if isinstance(value, BaseModel):
        value = value.model_dump(mode="json", exclude_defaults=True)
    if isinstance(value, str):
        return value if len(value) <= MAX_TEXT else value[: MAX_TEXT - 1] + "…"
    if isinstance(value, dict):
        return {str(k): _short(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_short(v) for v in value[:50]]
    return value


def summarise(result: CallToolResult) -> dict[str, Any]:
    """What a result event says about a tool result: its message, status, the structured content
    when it is small, and whether it carried an image."""
    structured = result.structured_content
    text = " ".join(c.text for c in result.content if isinstance(c, TextContent))
    said = [structured.get(k) for k in ("message", "reason")] if isinstance(structured, dict) else []
    summary = next((str(s) for s in said if s), text)
    out: dict[str, Any] = {
        "is_error": bool(result.is_error),
        "summary": _short(summary),
        "status": structured.get("status") if isinstance(structured, dict) else None,
    }
    if structured is not None and len(json.dumps(structured, ensure_ascii=False)) <= MAX_STRUCTURED:
        out["structured"] = structured
    return out


class EventBus:
    """The events of one server, for any number of viewers; see the module's docstring."""

    def __init__(self, *, backlog: int = BACKLOG, images: int = IMAGES) -> None:
        self._events: deque[Event] = deque(maxlen=backlog)
        self._images: OrderedDict[int, bytes] = OrderedDict()
        self._max_images = images
        self._seq = 0
        self._changed = anyio.Event()
        self._stale = anyio.Event()  # the world may have changed since the last snapshot
        self.closed = False
        self.state: dict[str, Any] | None = None  # the newest world snapshot
        self.state_seq = 0
        self.verdicts: dict[str, dict[str, Any]] = {}  # "believed" (end_task), "truth" (check_task)
        self.calls = 0

    @property
    def seq(self) -> int:
        return self._seq

    def publish(self, kind: str, data: dict[str, Any]) -> Event:
        self._seq += 1
        event = Event(self._seq, kind, data)
        self._events.append(event)
        self._changed.set()
        self._changed = anyio.Event()
        return event

    def since(self, after: int) -> list[Event]:
        """The events after `after`, or a `gap` event alone when some of them are no longer kept."""
        if not self._events or after >= self._seq:
            return []
        first = self._events[0].seq
        if after < first - 1:
            return [Event(self._seq, "gap", {"missed": first - 1 - after})]
        newer: list[Event] = []  # from the newest back: a reader that keeps up costs O(1), not O(backlog)
        for event in reversed(self._events):
            if event.seq <= after:
                break
            newer.append(event)
        newer.reverse()
        return newer

    def recent(self, n: int) -> list[Event]:
        return list(self._events)[-n:]

    def image(self, seq: int) -> bytes | None:
        return self._images.get(seq)

    async def follow(self, after: int, *, heartbeat_s: float | None = None) -> AsyncIterator[Event | None]:
        """Every event after `after` as it is published, until the bus closes; None after each
        `heartbeat_s` without one. After a `gap` the reader continues from the newest event."""
        async with aclosing(self._wake_ups(after, heartbeat_s)) as wake_ups:
            async for events in wake_ups:
                if not events:
                    yield None
                for event in events:
                    yield event

    async def batches(
        self, after: int, *, heartbeat_s: float | None = None, tick_s: float = 0.0
    ) -> AsyncIterator[bytes]:
        """Like `follow`, for a stream: the encoded events after `after` as one chunk per wake-up,
        at most one chunk per `tick_s` (what a reader costs the event loop is a write per tick, not
        per event, however fast the robot acts), and a keep-alive comment after `heartbeat_s`
        without any."""
        async with aclosing(self._wake_ups(after, heartbeat_s)) as wake_ups:
            async for events in wake_ups:
                if not events:
                    yield b": keep-alive\n\n"
                    continue
                yield b"".join(event.encoded for event in events)
                if tick_s:
                    await anyio.sleep(tick_s)

    async def _wake_ups(self, after: int, heartbeat_s: float | None) -> AsyncGenerator[list[Event]]:
        """The events after `after`, a list each time there are new ones, until the bus closes; an
        empty list after each `heartbeat_s` without any (the next list starts where the last ended)."""
        while not self.closed:
            events = self.since(after)
            if not events:
                changed = self._changed
                with anyio.move_on_after(heartbeat_s) as waiting:
                    await changed.wait()
                if waiting.cancelled_caught:
                    yield []
                continue
            after = events[-1].seq
            yield events

    def close(self) -> None:
        self.closed = True
        self._changed.set()
        self._stale.set()

    # --- the tool handler's side ------------------------------------------------------------------

    async def observe(
        self,
        tool: str,
        arguments: Mapping[str, Any],
        call: Callable[[], Awaitable[CallToolResult]],
        *,
        client: str | None = None,
    ) -> CallToolResult:
        """Run `call` (the tool call), publishing a `call` event before and a `result` event after
        (also when it raises), then mark the world for a new snapshot."""
        if tool not in CONTROL_TOOLS:  # the header counts the agent's calls, not a harness's begin/check_task
            self.calls += 1
        started = self.publish("call", {"tool": tool, "arguments": _short(dict(arguments)), "client": client})
        t0 = time.perf_counter()
        data: dict[str, Any] = {"call": started.seq, "tool": tool}
        image: ImageContent | None = None
        try:
            result = await call()
        except BaseException as exc:
            message = str(exc) or type(exc).__name__
            cancelled = isinstance(exc, anyio.get_cancelled_exc_class())
            data |= {"is_error": True, "summary": _short("cancelled" if cancelled else message), "status": None}
            raise
        else:
            data |= summarise(result)
            image = next((c for c in result.content if isinstance(c, ImageContent)), None)
            if image is not None:
                data["image"] = True
            happened = (result.meta or {}).get(PERTURBATION_META_KEY)
            if happened:  # what went wrong during the call: the page marks it in the list of calls
                data["perturbations"] = _short(happened)
            if not result.is_error:
                self._verdict(tool, arguments, result)
            if tool in VERDICT_TOOLS | EPISODE_TOOLS:
                data["verdicts"] = self.verdicts
            return result
        finally:
            data["duration_ms"] = round(1000 * (time.perf_counter() - t0), 1)
            event = self.publish("result", data)
            if image is not None:
                try:
                    self._keep_image(event.seq, base64.b64decode(image.data, validate=True))
                except ValueError:
                    logger.debug("%s returned an image that is not base64", tool)
            self._stale.set()

    def _verdict(self, tool: str, arguments: Mapping[str, Any], result: CallToolResult) -> None:
        """The episode's verdicts: what the agent believes (end_task's status and summary) and the
        ground truth (check_task's verdict); a new episode has neither."""
        structured = result.structured_content if isinstance(result.structured_content, dict) else {}
        if tool == "end_task":
            self.verdicts = self.verdicts | {
                "believed": {
                    "status": arguments.get("status"),
                    "summary": _short(arguments.get("summary")),
                    "episode": structured.get("episode"),
                }
            }
        elif tool == "check_task":
            self.verdicts = self.verdicts | {"truth": _short(structured)}
        elif tool in EPISODE_TOOLS:
            self.verdicts = {}

    def _keep_image(self, seq: int, png: bytes) -> None:
        self._images[seq] = png
        while len(self._images) > self._max_images:
            self._images.popitem(last=False)

    async def snapshots(self, snapshot: Snapshot) -> None:
        """Forever: after each call, read the world once (`snapshot`) and publish it as `state`."""
        while not self.closed:
            await self._stale.wait()
            if self.closed:
                return
            self._stale = anyio.Event()
            try:
                state = await snapshot()
            except Exception as exc:  # the robot is not available: nothing to show
                logger.debug("no world snapshot: %s", exc)
                continue
            self.state = state
            self.state_seq = self.publish("state", {"world": state, "verdicts": self.verdicts}).seq
