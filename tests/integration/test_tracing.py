"""OpenTelemetry: the SDK's per-message span middleware runs only when something records spans."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import anyio
from mcp import Client
from mcp.server._otel import OpenTelemetryMiddleware

from robocog.server.app import build_server
from robocog.server.config import SessionConfig


def test_without_a_tracer_provider_no_span_is_opened(tmp_path: Path) -> None:
    server = build_server(SessionConfig(data_dir=tmp_path / "memory"))
    assert not any(isinstance(m, OpenTelemetryMiddleware) for m in server.middleware)
    assert server.middleware, "the SDK's request-state boundary stays"

    async def call() -> None:
        async with Client(server) as client:
            result = await client.call_tool("view_scratchpad", {})
            assert not result.is_error

    anyio.run(call)


TRACED = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path

    import anyio
    from mcp import Client
    from opentelemetry import trace
    from opentelemetry.sdk.trace import TracerProvider
    from opentelemetry.sdk.trace.export import SimpleSpanProcessor
    from opentelemetry.sdk.trace.export.in_memory_span_exporter import InMemorySpanExporter

    exporter = InMemorySpanExporter()
    provider = TracerProvider()
    provider.add_span_processor(SimpleSpanProcessor(exporter))
    trace.set_tracer_provider(provider)

    from robocog.server.app import build_server
    from robocog.server.config import SessionConfig

    server = build_server(SessionConfig(data_dir=Path(sys.argv[1])))

    async def main() -> None:
        async with Client(server) as client:
            await client.call_tool("view_scratchpad", {})
            await client.call_tool("move_to", {"location": 5})

    anyio.run(main)
    print(json.dumps([[s.name, s.attributes.get("error.type")] for s in exporter.get_finished_spans()]))
    """
)


def test_with_a_tracer_provider_every_call_is_a_span(tmp_path: Path) -> None:
    """A provider installed before the server is built (as `opentelemetry-instrument` does) keeps the
    SDK's middleware: each call is a server span, a rejected one marked as an error."""
    done = subprocess.run(
        [sys.executable, "-c", TRACED, str(tmp_path / "memory")], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    spans = json.loads(done.stdout.strip().splitlines()[-1])
    assert ["tools/call view_scratchpad", None] in spans
    assert any(name == "tools/call move_to" and error is not None for name, error in spans), spans
