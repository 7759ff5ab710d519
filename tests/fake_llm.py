"""A scripted model service on loopback, speaking three provider APIs over real HTTP.

One server answers all three routes LiteLLM knows, non-streaming JSON only:

- OpenAI chat completions  ``POST /v1/chat/completions``  (LiteLLM: ``openai/NAME``, ``api_base=srv.openai_base``)
- Anthropic messages       ``POST /v1/messages``          (LiteLLM: ``anthropic/NAME``, ``api_base=srv.anthropic_base``)
- Ollama chat              ``POST /api/chat``             (LiteLLM: ``ollama_chat/NAME``, ``api_base=srv.ollama_base``)

What it answers comes from a *script*: a callable ``(Request) -> reply`` or a sequence of replies
served in order. A reply is a neutral `Turn` (text and/or tool calls, rendered in the provider's own
format), a `Fail` (an HTTP error in the provider's error format, e.g. 429 with ``Retry-After``), a
`Raw` body, or a plain dict (sent as is with 200). Turns and fails may carry a ``delay`` (seconds
before answering: longer than the client's timeout makes a timeout). Every request is recorded
(`FakeLLM.requests`: path, headers, JSON body, and the server's own time on it).

`planner_script()` makes the repo's scripted planner answer through HTTP: each request's messages
are turned back into neutral OpenAI-style messages (`neutral_messages`) and `decide()` picks the
next call, so a full episode runs through a real provider route.

    with FakeLLM([Turn(tool_calls=[("look_around", {})]), Turn(text="done")]) as srv:
        litellm.completion(model="openai/fake", api_base=srv.openai_base, api_key="sk-no-key-required", ...)
        srv.requests[0].body

As a pytest fixture: ``from tests.fake_llm import fake_llm_fixture  # noqa: F401``, then take
``fake_llm`` (a started server; script it with ``fake_llm.script = ...`` or ``fake_llm.reply(...)``).
From a shell, for trying the CLI by hand: ``python tests/fake_llm.py --port 8765`` serves the
planner on all routes.

Loopback only, no dependency beyond the standard library (the planner is imported on demand).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Literal

Provider = Literal["openai", "anthropic", "ollama"]

PATHS: dict[str, Provider] = {
    "/v1/chat/completions": "openai",
    "/chat/completions": "openai",  # an api_base given without /v1
    "/v1/messages": "anthropic",
    "/api/chat": "ollama",
}

#: What ``POST /api/show`` answers: a tool-capable model with a 32k context.
OLLAMA_SHOW: dict[str, Any] = {
    "template": "{{- if .Tools }}{{ .Tools }}{{ end }}{{ .Prompt }}",
    "details": {"family": "fake", "parameter_size": "1B", "quantization_level": "Q4_K_M"},
    "model_info": {"general.architecture": "fake", "fake.context_length": 32768},
    "capabilities": ["completion", "tools"],
}

#: The key to give LiteLLM for a keyless server (what a llama.cpp / vLLM user would pass).
PLACEHOLDER_KEY = "sk-no-key-required"


# --- what a script returns -----------------------------------------------------------------------


@dataclass
class Turn:
    """One assistant turn, provider-neutral.

    ``tool_calls``: ``(name, arguments)`` pairs; arguments as a dict, or as a raw string sent verbatim
    (e.g. ``'{"object": "apple"'`` for malformed JSON). ``usage``: ``(prompt_tokens, completion_tokens)``;
    by default an estimate of 4 characters a token over the request and the turn. ``delay``: seconds
    to wait before answering. ``ids``: tool call ids to use instead of generated ones.
    """

    text: str | None = None
    tool_calls: list[tuple[str, dict[str, Any] | str]] = field(default_factory=list)
    usage: tuple[int, int] | None = None
    delay: float = 0.0
    ids: list[str] | None = None


@dataclass
class Fail:
    """An HTTP error in the provider's error format, e.g. ``Fail(429, headers={"Retry-After": "7"})``."""

    status: int
    message: str = ""
    headers: dict[str, str] = field(default_factory=dict)
    delay: float = 0.0


@dataclass
class Raw:
    """A response sent exactly as given (``body``: a dict is sent as JSON, bytes/str verbatim)."""

    body: dict[str, Any] | str | bytes
    status: int = 200
    headers: dict[str, str] = field(default_factory=dict)
    delay: float = 0.0


Reply = Turn | Fail | Raw | dict
Script = Callable[["Request"], Reply] | Iterable[Reply]


@dataclass
class Request:
    """A request the server received (headers with lower-case names)."""

    provider: Provider | None
    method: str
    path: str
    headers: dict[str, str]
    body: Any
    received: float = 0.0  # time.perf_counter() when the body had been read
    server_s: float = 0.0  # the server's own time on it (request line in -> response out), scripted delay excluded
    delay_s: float = 0.0  # the scripted delay it was answered after
    status: int = 0

    @property
    def messages(self) -> list[dict[str, Any]]:
        """The messages in the provider's own format."""
        return list((self.body or {}).get("messages") or []) if isinstance(self.body, dict) else []

    def neutral(self) -> list[dict[str, Any]]:
        """The conversation as OpenAI-style messages (system/user/assistant with tool_calls/tool)."""
        return neutral_messages(self.provider or "openai", self.body if isinstance(self.body, dict) else {})

    def images(self) -> list[tuple[str, str]]:
        """Every picture the request carries, as (role of its message, base64 data), in the provider's
        own format: OpenAI `image_url` parts with data URLs, Anthropic `image` blocks with a base64
        source (also inside tool results), Ollama's `images` lists."""
        found: list[tuple[str, str]] = []

        def walk(role: str, content: Any) -> None:
            for part in content if isinstance(content, list) else []:
                if not isinstance(part, dict):
                    continue
                if part.get("type") == "image_url":
                    url = part["image_url"]["url"] if isinstance(part.get("image_url"), dict) else part["image_url"]
                    found.append((role, str(url).split(",", 1)[-1]))
                elif part.get("type") == "image" and isinstance(part.get("source"), dict):
                    found.append((role, str(part["source"].get("data", ""))))
                elif part.get("type") == "tool_result":
                    walk(role, part.get("content"))

        for message in self.messages:
            role = str(message.get("role", ""))
            walk(role, message.get("content"))
            found.extend((role, str(image)) for image in message.get("images") or [])
        return found

    @property
    def api_key(self) -> str | None:
        """The credential the client sent (Bearer token or x-api-key), if any."""
        auth = self.headers.get("authorization")
        if auth:
            return auth.split(" ", 1)[1] if auth.lower().startswith("bearer ") else auth
        return self.headers.get("x-api-key")


# --- provider formats ----------------------------------------------------------------------------


def _counter() -> Iterator[str]:
    return (f"{n:04d}" for n in itertools.count(1))


def _estimate(value: Any) -> int:
    return max(1, len(json.dumps(value, default=str)) // 4)


def _args_json(arguments: dict[str, Any] | str) -> str:
    return arguments if isinstance(arguments, str) else json.dumps(arguments)


def render(
    provider: Provider,
    turn: Turn,
    request_body: dict[str, Any] | None = None,
    ids: Iterator[str] | None = None,
    *,
    ollama_ids: bool = False,
) -> dict[str, Any]:
    """`turn` as a successful response body of `provider`, answering `request_body`.

    ``ids`` numbers the tool calls and the response (``call_0001``, ``toolu_0001``...; a fresh count by
    default). Ollama sends no tool call ids unless ``ollama_ids`` (or the turn's own ``ids``).
    """
    request_body = request_body or {}
    ids = ids if ids is not None else _counter()
    model = str(request_body.get("model", "fake"))
    prompt, completion = turn.usage or (
        _estimate(request_body.get("messages")) + _estimate(request_body.get("tools") or []),
        _estimate([turn.text, turn.tool_calls]),
    )
    prefix = "toolu_" if provider == "anthropic" else "call_"
    call_ids = list(turn.ids or [])
    call_ids += [prefix + next(ids) for _ in range(len(turn.tool_calls) - len(call_ids))]
    now = int(time.time())
    if provider == "openai":
        message: dict[str, Any] = {"role": "assistant", "content": turn.text}
        if turn.tool_calls:
            message["tool_calls"] = [
                {"id": i, "type": "function", "function": {"name": name, "arguments": _args_json(args)}}
                for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True)
            ]
        return {
            "id": f"chatcmpl-{next(ids)}",
            "object": "chat.completion",
            "created": now,
            "model": model,
            "choices": [{"index": 0, "message": message, "finish_reason": "tool_calls" if turn.tool_calls else "stop"}],
            "usage": {"prompt_tokens": prompt, "completion_tokens": completion, "total_tokens": prompt + completion},
        }
    if provider == "anthropic":
        content: list[dict[str, Any]] = []
        if turn.text:
            content.append({"type": "text", "text": turn.text})
        for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True):
            # The real API always sends an object; a raw string is passed through for malformed-input tests.
            content.append({"type": "tool_use", "id": i, "name": name, "input": args})
        return {
            "id": f"msg_{next(ids)}",
            "type": "message",
            "role": "assistant",
            "model": model,
            "content": content,
            "stop_reason": "tool_use" if turn.tool_calls else "end_turn",
            "stop_sequence": None,
            "usage": {"input_tokens": prompt, "output_tokens": completion},
        }
    # Ollama: arguments are objects; ids are sent only when the server is told to (`ollama_ids`).
    message = {"role": "assistant", "content": turn.text or ""}
    if turn.tool_calls:
        message["tool_calls"] = [
            {"function": {"name": name, "arguments": args}, **({"id": i} if turn.ids or ollama_ids else {})}
            for i, (name, args) in zip(call_ids, turn.tool_calls, strict=True)
        ]
    return {
        "model": model,
        "created_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "message": message,
        "done": True,
        "done_reason": "stop",
        "prompt_eval_count": prompt,
        "eval_count": completion,
    }


_ERROR_TYPES = {
    400: "invalid_request_error",
    401: "authentication_error",
    403: "permission_error",
    404: "not_found_error",
    429: "rate_limit_error",
    500: "api_error",
    529: "overloaded_error",
}


def render_error(provider: Provider | None, fail: Fail) -> dict[str, Any]:
    """`fail` as an error body of `provider`."""
    kind = _ERROR_TYPES.get(fail.status, "api_error")
    message = fail.message or f"fake_llm: scripted HTTP {fail.status} ({kind})"
    if provider == "anthropic":
        return {"type": "error", "error": {"type": kind, "message": message}}
    if provider == "ollama":
        return {"error": message}
    return {"error": {"message": message, "type": kind, "param": None, "code": str(fail.status)}}


def _text_of(content: Any) -> str:
    if content is None:
        return ""
    if isinstance(content, str):
        return content
    if isinstance(content, list):
        return "".join(b.get("text", "") if isinstance(b, dict) else str(b) for b in content)
    return str(content)


def neutral_messages(provider: Provider, body: dict[str, Any]) -> list[dict[str, Any]]:
    """A provider request's conversation as OpenAI-style message dicts, as the planner reads them.

    Anthropic: the top-level ``system`` becomes a system message; ``tool_use`` blocks become
    ``tool_calls`` (arguments re-serialised as JSON); ``tool_result`` blocks become ``tool`` messages.
    Ollama: LiteLLM drops the ids of the assistant's tool calls but keeps ``tool_call_id`` on the
    tool messages, so each call takes the id of the tool message that answers it (by position).
    """
    messages = list(body.get("messages") or [])
    out: list[dict[str, Any]] = []
    if provider == "anthropic":
        if body.get("system"):
            out.append({"role": "system", "content": _text_of(body["system"])})
        for m in messages:
            content = m.get("content")
            blocks = content if isinstance(content, list) else [{"type": "text", "text": content or ""}]
            if m.get("role") == "assistant":
                text = "".join(b.get("text", "") for b in blocks if b.get("type") == "text")
                calls = [
                    {
                        "id": b.get("id"),
                        "type": "function",
                        "function": {"name": b.get("name"), "arguments": _args_json(b.get("input", {}))},
                    }
                    for b in blocks
                    if b.get("type") == "tool_use"
                ]
                msg: dict[str, Any] = {"role": "assistant", "content": text or None}
                if calls:
                    msg["tool_calls"] = calls
                out.append(msg)
                continue
            texts = []
            for b in blocks:
                if b.get("type") == "tool_result":
                    out.append(
                        {"role": "tool", "tool_call_id": b.get("tool_use_id"), "content": _text_of(b.get("content"))}
                    )
                elif b.get("type") == "text":
                    texts.append(b.get("text", ""))
            if texts:
                out.append({"role": m.get("role", "user"), "content": "".join(texts)})
        return out
    if provider == "ollama":
        counter = itertools.count(1)
        for n, m in enumerate(messages):
            msg = {"role": m.get("role"), "content": _text_of(m.get("content"))}
            if m.get("role") == "assistant":
                calls = m.get("tool_calls") or []
                if not msg["content"]:
                    msg["content"] = None
                if calls:
                    answers = [
                        x.get("tool_call_id")
                        for x in itertools.takewhile(lambda x: x.get("role") == "tool", messages[n + 1 :])
                    ]
                    msg["tool_calls"] = []
                    for i, c in enumerate(calls):
                        fn = c.get("function") or {}
                        call_id = c.get("id") or (answers[i] if i < len(answers) and answers[i] else None)
                        msg["tool_calls"].append(
                            {
                                "id": call_id or f"ollama_call_{next(counter)}",
                                "type": "function",
                                "function": {"name": fn.get("name"), "arguments": _args_json(fn.get("arguments", {}))},
                            }
                        )
            elif m.get("role") == "tool":
                msg["tool_call_id"] = m.get("tool_call_id")
            out.append(msg)
        # tool messages without an id: pair them by position with the calls before them
        pending: deque[str] = deque()
        for msg in out:
            if msg["role"] == "assistant":
                pending = deque(c["id"] for c in msg.get("tool_calls") or [])
            elif msg["role"] == "tool":
                expected = pending.popleft() if pending else None
                if not msg.get("tool_call_id"):
                    msg["tool_call_id"] = expected
        return out
    for m in messages:  # OpenAI: already neutral; content blocks flattened to text
        msg = dict(m)
        if isinstance(msg.get("content"), list):
            msg["content"] = _text_of(msg["content"])
        out.append(msg)
    return out


# --- scripts -------------------------------------------------------------------------------------


def planner_script(variant: str = "planner", *, seed: int | None = None, p: float = 0.3) -> Callable[[Request], Turn]:
    """A script in which the repo's scripted planner decides every turn, read back from HTTP."""
    from robocog.agent.policies.planner import decide

    def script(request: Request) -> Turn:
        call = decide(request.neutral(), variant, seed=seed, p=p)  # type: ignore[arg-type]
        if call.name is None:
            return Turn(text=call.text)
        return Turn(tool_calls=[(call.name, dict(call.arguments))])

    return script


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
        self._ids = _counter()
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


try:
    import pytest
except ImportError:  # a benchmark without pytest
    pass
else:

    @pytest.fixture(name="fake_llm")
    def fake_llm_fixture() -> Iterator[FakeLLM]:
        """The ``fake_llm`` fixture: a started `FakeLLM` with no script (set ``.script`` or call ``.reply(...)``).

        Use it with ``from tests.fake_llm import fake_llm_fixture  # noqa: F401`` in a test module.
        """
        with FakeLLM() as server:
            yield server
        assert not server.problems, server.problems


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(
        description="Serve the scripted planner over the OpenAI, Anthropic and Ollama APIs."
    )
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--variant", default="planner", choices=["planner", "overconfident", "refuser"])
    args = parser.parse_args()
    with FakeLLM(planner_script(args.variant), port=args.port) as server:
        print(f"openai:    --model openai/fake --api-base {server.openai_base}")
        print(f"anthropic: --model anthropic/fake --api-base {server.anthropic_base}")
        print(f"ollama:    --model ollama_chat/fake --api-base {server.ollama_base}", flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            threading.Event().wait()


if __name__ == "__main__":
    main()
