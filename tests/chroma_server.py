"""A real Chroma server for the tests that need one: `chroma run`, the CLI shipped with chromadb."""

from __future__ import annotations

import os
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.helpers import free_port


@contextmanager
def chroma_server(path: Path) -> Iterator[str]:
    """A `chroma run` server storing under `path`, on a free loopback port: its URL, once it answers
    its heartbeat."""
    chroma = Path(sys.executable).parent / "chroma"
    command = [str(chroma)] if chroma.exists() else [sys.executable, "-c", "from chromadb.cli.cli import app; app()"]
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    proc = subprocess.Popen(
        [*command, "run", "--path", str(path), "--host", "127.0.0.1", "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "ANONYMIZED_TELEMETRY": "False"},
    )
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                urllib.request.urlopen(f"{url}/api/v2/heartbeat", timeout=1).close()
                break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"chroma run did not answer {url} (exit code {proc.poll()})") from None
                time.sleep(0.1)
        yield url
    finally:
        proc.terminate()
        proc.wait(timeout=15)
