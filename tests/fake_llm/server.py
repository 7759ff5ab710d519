"""The server: one loopback HTTP server answering the three provider routes from a script, and
recording every request (`FakeLLM`)."""

from __future__ import annotations

import json
import threading
import time
from collections import deque
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from tests.fake_llm.format_helpers import counter
from tests.fake_llm.formats import render, render_error
from tests.fake_llm.ollama_api import OLLAMA_SHOW
from tests.fake_llm.replies import Fail, Provider, Raw, Reply, Request, Script, Turn

PATHS: dict[str, Provider] = {
    "/v1/chat/completions": "openai",
    "/chat/completions": "openai",  # an api_base given without /v1
    "/v1/messages": "anthropic",
    "/api/chat": "ollama",
}

#: The key to give LiteLLM for a keyless server (what a llama.cpp / vLLM user would pass).
PLACEHOLDER_KEY = "sk-no-key-required"


def _as_callable(script: Script | None) -> Callable[[Request], Reply]:
    if script is None:
        return lambda request: Fail(500, "fake_llm: no script set")
    if callable(script):
        return script
    queue: deque[Reply] = deque(script)
    lock = threading.Lock()

    def next_reply(request: Request) -> Reply:
        with lock:
            if queue:
                return queue.popleft()
        return Fail(500, "fake_llm: the script has no more replies")

    return next_reply


# --- the server ----------------------------------------------------------------------------------


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"  # keep-alive, as LiteLLM's httpx clients expect
    disable_nagle_algorithm = True  # small responses must not wait for delayed ACKs
    _started = 0.0  # time.perf_counter() when the current request's first line was read
    server: _Server

    def log_message(self, format: str, *args: Any) -> None:  # quiet
        pass

    def parse_request(self) -> bool:
        self._started = time.perf_counter()  # the request line is in: the server's own time starts
        return super().parse_request()

    def do_GET(self) -> None:  # model lists (/v1/models, /api/tags) and health checks: empty, but valid
        with self.server.fake._lock:
            self.server.fake.requests.append(
                Request(None, "GET", self.path, {k.lower(): v for k, v in self.headers.items()}, None)
            )
        self._send(200, {"object": "list", "data": [], "models": []})

    def do_POST(self) -> None:
        fake = self.server.fake
        length = int(self.headers.get("Content-Length") or 0)
        raw = self.rfile.read(length) if length else b""
        received = time.perf_counter()
        try:
            body: Any = json.loads(raw) if raw else None
        except json.JSONDecodeError:
            body = raw.decode("utf-8", "replace")
        path = self.path.split("?", 1)[0].rstrip("/")
        provider = PATHS.get(path)
        request = Request(
            provider=provider,
            method="POST",
            path=self.path,
            headers={k.lower(): v for k, v in self.headers.items()},
            body=body,
            received=received,
        )
        with fake._lock:
            fake.requests.append(request)
        if path == "/api/show":  # LiteLLM asks an Ollama server about the model (for pricing and context size)
            reply: Reply = Raw(OLLAMA_SHOW)
        elif provider is None:
            reply = Fail(404, f"fake_llm: no route {self.path}")
        else:
            try:
                reply = fake._script(request)
            except Exception as exc:  # a broken script: answer loudly, and keep it for the test to see
                fake.problems.append(f"{type(exc).__name__}: {exc}")
                reply = Fail(500, f"fake_llm: the script raised {type(exc).__name__}: {exc}")
        delay = getattr(reply, "delay", 0.0) if not isinstance(reply, dict) else 0.0
        status, payload, headers = self._render(provider, reply, body if isinstance(body, dict) else {})
        request.status, request.delay_s = status, delay
        if delay and fake._stopping.wait(delay):
            return  # stopping: drop the connection
        try:
            self._send(status, payload, headers, request)
        except OSError:  # the client gave up (a timeout): nothing to answer
            self.close_connection = True

    def _render(self, provider: Provider | None, reply: Reply, body: dict[str, Any]) -> tuple[int, Any, dict[str, str]]:
        fake = self.server.fake
        if isinstance(reply, dict):
            return 200, reply, {}
        if isinstance(reply, Raw):
            return reply.status, reply.body, reply.headers
        if isinstance(reply, Fail):
            return reply.status, render_error(provider, reply), reply.headers
        if isinstance(reply, Turn):
            return 200, render(provider or "openai", reply, body, fake._ids, ollama_ids=fake.ollama_ids), {}
        fake.problems.append(f"not a reply: {reply!r}")
        return 500, render_error(provider, Fail(500, f"fake_llm: the script returned {type(reply).__name__}")), {}

    def _send(
        self, status: int, payload: Any, headers: dict[str, str] | None = None, request: Request | None = None
    ) -> None:
        if isinstance(payload, bytes):
            data, kind = payload, "application/octet-stream"
        elif isinstance(payload, str):
            data, kind = payload.encode(), "text/plain"
        else:
            data, kind = json.dumps(payload).encode(), "application/json"
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(data)))
        for k, v in (headers or {}).items():
            self.send_header(k, v)
        self.end_headers()
        if request is not None:  # up to the last byte handed to the socket: the client's time from here
            request.server_s = time.perf_counter() - self._started - request.delay_s
        self.wfile.write(data)


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True
    fake: FakeLLM

    def handle_error(self, request: Any, client_address: Any) -> None:  # a dropped connection is not news
        pass


class FakeLLM:
    """The scripted model service. `start()` (or ``with``) binds a free port on 127.0.0.1."""

    def __init__(self, script: Script | None = None, *, port: int = 0, ollama_ids: bool = False) -> None:
        self.port = port
        self.ollama_ids = ollama_ids  # Ollama answers with tool call ids (newer servers do; LiteLLM then keeps them)
        self.requests: list[Request] = []
        self.problems: list[str] = []  # scripts that raised, replies that were not replies
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._ids = counter()
        self._script = _as_callable(script)
        self._server: _Server | None = None
        self._thread: threading.Thread | None = None

    # scripting
    @property
    def script(self) -> Callable[[Request], Reply]:
        return self._script

    @script.setter
    def script(self, script: Script | None) -> None:
        self._script = _as_callable(script)

    def reply(self, *replies: Reply) -> FakeLLM:
        """Answer the next requests with these replies, in order (replaces the script)."""
        self.script = list(replies)
        return self

    def reset(self) -> None:
        """Forget the recorded requests and problems."""
        with self._lock:
            self.requests.clear()
            self.problems.clear()

    # addresses
    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def openai_base(self) -> str:
        return f"{self.url}/v1"

    @property
    def anthropic_base(self) -> str:
        return self.url  # LiteLLM appends /v1/messages

    @property
    def ollama_base(self) -> str:
        return self.url  # LiteLLM appends /api/chat

    def api_base(self, model: str) -> str:
        """The api_base to give LiteLLM for a model string (``openai/...``, ``anthropic/...``, ``ollama_chat/...``)."""
        route = model.split("/", 1)[0]
        return {"anthropic": self.anthropic_base, "ollama_chat": self.ollama_base, "ollama": self.ollama_base}.get(
            route, self.openai_base
        )

    @property
    def model_requests(self) -> list[Request]:
        """The chat requests only (not LiteLLM's side requests such as Ollama's ``/api/show``)."""
        with self._lock:
            return [r for r in self.requests if r.provider is not None]

    @property
    def last(self) -> Request:
        """The last chat request."""
        return self.model_requests[-1]

    # life
    def start(self) -> FakeLLM:
        if self._server is not None:
            return self
        self._stopping.clear()
        self._server = _Server(("127.0.0.1", self.port), _Handler)
        self._server.fake = self
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.01}, daemon=True)
        self._thread.name = f"fake-llm-{self.port}"
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._server is None:
            return
        self._stopping.set()  # wakes handlers sleeping on a scripted delay
        self._server.shutdown()
        self._server.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._server = self._thread = None

    def __enter__(self) -> FakeLLM:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
