"""The servers under attack: `robocog-server --profile eval` over stdio, spoken to in raw JSON-RPC lines
(`StdioServer`), and over HTTP on a free loopback port; what a process costs (CPU time, RSS)."""

from __future__ import annotations

import json
import math
import os
import select
import socket
import subprocess
import time
from pathlib import Path
from typing import Any

from tests.helpers import free_port, server_command

#: Longer than this without an answer, the server is hung (a 10 MB call included).
ANSWER_TIMEOUT_S = 120.0


def server_env() -> dict[str, str]:
    """The server's environment, without a token a developer may have set (the clients send none)."""
    env = {k: v for k, v in os.environ.items() if k != "ROBOCOG_AUTH_TOKEN"}
    return env | {"ANONYMIZED_TELEMETRY": "False", "COLUMNS": "240"}  # wide log lines: one record, one line


# --- the server's process -----------------------------------------------------------------------------


class Died(Exception):
    """The server's stdout closed, or it did not answer in time."""


def cpu_seconds(pid: int) -> float:
    """utime + stime of the process (all its threads), seconds."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return math.nan


class StdioServer:
    """`robocog-server --profile eval` over stdio, spoken to in raw JSON-RPC lines, one call at a time."""

    def __init__(self, data: Path, log: Path) -> None:
        self.log = log.open("ab")
        self.proc = subprocess.Popen(
            [*server_command(), "--profile", "eval", "--data-dir", str(data)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            env=server_env(),
        )
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.stdin = self.proc.stdin
        self.fd = self.proc.stdout.fileno()
        self.buffer = b""
        self.next_id = 0
        self.request(
            "initialize",
            {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "fuzz", "version": "1"}},
        )
        self.send_line(json.dumps({"jsonrpc": "2.0", "method": "notifications/initialized"}).encode())

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def send_line(self, line: bytes) -> None:
        try:
            self.stdin.write(line + b"\n")
            self.stdin.flush()
        except (BrokenPipeError, OSError) as exc:
            raise Died(f"writing: {exc}") from exc

    def encode(self, method: str, params: Any) -> tuple[int, bytes]:
        self.next_id += 1
        message = {"jsonrpc": "2.0", "id": self.next_id, "method": method, "params": params}
        return self.next_id, json.dumps(message).encode()  # NaN and lone surrogates go as Python writes them

    def request(self, method: str, params: Any) -> dict[str, Any]:
        request_id, line = self.encode(method, params)
        self.send_line(line)
        return self.answer(request_id)

    def answer(self, request_id: int) -> dict[str, Any]:
        """The response to `request_id`; notifications and other responses on the way are skipped."""
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        while True:
            while b"\n" not in self.buffer:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not select.select([self.fd], [], [], remaining)[0]:
                    raise Died(f"no answer to request {request_id} in {ANSWER_TIMEOUT_S:.0f} s")
                chunk = os.read(self.fd, 1 << 20)
                if not chunk:
                    raise Died("stdout closed")
                self.buffer += chunk
            line, self.buffer = self.buffer.split(b"\n", 1)
            if not line.strip():
                continue
            message = json.loads(line)
            if isinstance(message, dict) and message.get("id") == request_id and "method" not in message:
                return message

    def close(self) -> None:
        if self.alive():
            self.proc.kill()
        self.proc.wait()
        self.log.close()


def start_http_server(work: Path) -> tuple[subprocess.Popen[bytes], str]:
    port = free_port()
    log = (work / "http.log").open("wb")
    command = [*server_command(), "--transport", "http", "--port", str(port), "--profile", "eval"]
    proc = subprocess.Popen(
        [*command, "--data-dir", str(work / "http-memory")], stdout=log, stderr=subprocess.STDOUT, env=server_env()
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"the HTTP server exited: {(work / 'http.log').read_text()}")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return proc, f"http://127.0.0.1:{port}/mcp"
        time.sleep(0.1)
    proc.kill()
    raise RuntimeError("the HTTP server did not listen within 60 s")
