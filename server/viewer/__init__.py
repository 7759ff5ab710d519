"""The live viewer: a web page on loopback that shows the robot while any client drives it.

`robocog-server --view [PORT]` starts it inside the MCP server's own process (the lifespan's task
group, on the server's event loop), so it shows what Claude Desktop does over stdio as well as
what `robocog run --view` does. The page (`static/live.html`, plain HTML/JS/CSS, no build step,
nothing from the network) draws the top-down map on a canvas from JSON: the scene's geometry once
(`/api/scene`), then world snapshots and tool calls as server-sent events (`/api/events`, from
`robocog.server.events`). The camera image is rendered when the page asks for it
(`/api/camera.png`), once per world snapshot whatever the number of pages.

Loopback only: the socket is bound to 127.0.0.1 and requests naming another host are refused
(DNS rebinding). The page only reads: nothing on it can drive the robot.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import anyio
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from robocog.server.events import EventBus
from robocog.server.world.geometry import map_geometry
from robocog.shared.web import LOOPBACK_HOSTS, VIEWER_STATIC

if TYPE_CHECKING:
    from robocog.server.robots.session import RobotSession
    from robocog.server.state import AppState

logger = logging.getLogger("robocog.server.viewer")

#: `robocog-server --view` without a port.
DEFAULT_PORT = 8766
HOST = "127.0.0.1"
#: Events a page gets with the current state (the rows it starts with).
RECENT = 100
#: Seconds between keep-alive comments on an idle event stream (a closed page is noticed then).
HEARTBEAT_S = 10.0
#: Event streams open at once; past it a reader gets 503 (they share the robot's event loop).
MAX_READERS = 16
#: A reader is sent what happened at most this often (seconds), all of it in one write.
TICK_S = 0.5


def scene_json(session: RobotSession) -> dict[str, Any]:
    """The scene's geometry for drawing the map (`robocog.server.world.geometry`)."""
    return map_geometry(session.world)


def world_json(session: RobotSession) -> dict[str, Any]:
    """The ground truth as the page draws it."""
    return session.state().model_dump(mode="json")


class _Embedded:
    """uvicorn serving on a socket we bound, without taking the process's signals (the MCP server
    owns Ctrl-C and SIGTERM)."""

    def __init__(self, app: Any, sock: socket.socket) -> None:
        import uvicorn

        class Server(uvicorn.Server):
            @contextlib.contextmanager
            def capture_signals(self) -> Iterator[None]:
                yield

        config = uvicorn.Config(app, log_config=None, log_level="warning", lifespan="off", timeout_graceful_shutdown=1)
        self.server = Server(config)
        self.sock = sock

    async def serve(self) -> None:
        await self.server.serve(sockets=[self.sock])

    def stop(self) -> None:
        self.server.should_exit = True


class Viewer:
    """The live viewer of one server: its event bus, its web app and the socket it serves on."""

    def __init__(
        self, state: AppState, bus: EventBus, port: int = DEFAULT_PORT, *, max_readers: int = MAX_READERS
    ) -> None:
        self.state = state
        self.bus = bus
        self.port = port
        self.max_readers = max_readers
        #: Event streams open now.
        self.readers = 0
        self._scene: dict[str, Any] | None = None
        self._camera: dict[tuple[int, str], bytes] = {}
        self._camera_lock = anyio.Lock()
        self._server: _Embedded | None = None
        #: Set by `stop`, which may come before `run` has begun to serve (a client that closed at once).
        self._stopped = False

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.port}/"

    def app(self) -> Starlette:
        routes = [
            Route("/", self.index),
            Route("/api/scene", self.scene),
            Route("/api/state", self.current),
            Route("/api/events", self.events),
            Route("/api/camera.png", self.camera),
            Route("/api/images/{seq:int}.png", self.image),
            Mount("/static", StaticFiles(directory=VIEWER_STATIC), name="static"),
        ]
        middleware = [Middleware(TrustedHostMiddleware, allowed_hosts=LOOPBACK_HOSTS)]
        return Starlette(routes=routes, middleware=middleware)

    async def run(self) -> None:
        """Serve until `stop`, and publish a world snapshot after every call meanwhile. A port
        that is taken is reported on stderr; the MCP server carries on without its viewer."""
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((HOST, self.port))
            sock.listen(64)
        except OSError as exc:
            sock.close()
            print(f"robocog-server: the live viewer cannot listen on {HOST}:{self.port}: {exc}", file=sys.stderr)
            return
        if self._stopped:  # the server stopped before its viewer began
            sock.close()
            return
        sock.setblocking(False)
        self.port = sock.getsockname()[1]
        print(f"robocog-server: live viewer at {self.url}", file=sys.stderr, flush=True)
        self._server = _Embedded(self.app(), sock)

        async def snapshot() -> dict[str, Any]:
            return await self.state.run(world_json)

        async with anyio.create_task_group() as tg:
            tg.start_soon(self.bus.snapshots, snapshot)
            await self._server.serve()
            tg.cancel_scope.cancel()

    def stop(self) -> None:
        self._stopped = True
        self.bus.close()
        if self._server is not None:
            self._server.stop()

    # --- the routes -------------------------------------------------------------------------------

    async def index(self, request: Request) -> Response:
        return FileResponse(VIEWER_STATIC / "live.html", headers={"Cache-Control": "no-store"})

    def _ready(self) -> bool:
        return self.state.ready.is_set() and self.state.failure is None

    def _not_ready(self) -> JSONResponse:
        why = self.state.failure or "the robot is starting"
        return JSONResponse({"ready": False, "reason": why}, status_code=503)

    async def scene(self, request: Request) -> Response:
        if not self._ready():
            return self._not_ready()
        if self._scene is None:
            self._scene = await self.state.run(scene_json)
        return JSONResponse(self._scene)

    async def current(self, request: Request) -> Response:
        """The page's starting point: the world now, the recent events and the verdicts, and the
        seq to follow the event stream from."""
        if not self._ready():
            return self._not_ready()
        seq = self.bus.seq
        world = await self.state.run(world_json)
        return JSONResponse(
            {
                "ready": True,
                "seq": seq,
                "world": world,
                "verdicts": self.bus.verdicts,
                "calls": self.bus.calls,
                "events": [e.as_json() for e in self.bus.recent(RECENT) if e.kind in ("call", "result")],
            }
        )

    async def events(self, request: Request) -> Response:
        """Server-sent events from `after` (or the Last-Event-ID a reconnecting browser sends)."""
        try:
            after = int(request.headers.get("last-event-id") or request.query_params.get("after") or self.bus.seq)
        except ValueError:
            return JSONResponse({"error": "after must be a whole number"}, status_code=400)
        if self.readers >= self.max_readers:
            return JSONResponse(
                {
                    "error": f"the live viewer serves at most {self.max_readers} event streams at once and all are "
                    "open; close a viewer page and reload this one"
                },
                status_code=503,
                headers={"Retry-After": "5"},
            )
        self.readers += 1  # counted now (a burst of readers cannot overshoot the cap), until the stream ends

        async def stream() -> Any:
            yield b"retry: 1000\n\n"
            async for chunk in self.bus.batches(after, heartbeat_s=HEARTBEAT_S, tick_s=TICK_S):
                yield chunk

        viewer = self

        class Counted(StreamingResponse):
            async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
                try:
                    await super().__call__(scope, receive, send)
                finally:
                    viewer.readers -= 1

        headers = {"Cache-Control": "no-store", "X-Accel-Buffering": "no"}
        return Counted(stream(), media_type="text/event-stream", headers=headers)

    async def camera(self, request: Request) -> Response:
        """The robot's camera now (PNG), rendered once per world snapshot and direction."""
        from robocog.server.world.camera import DIRECTIONS, render_camera

        if not self._ready():
            return self._not_ready()
        direction = request.query_params.get("direction", "ahead")
        if direction not in DIRECTIONS:
            return JSONResponse({"error": f"direction: one of {', '.join(DIRECTIONS)}"}, status_code=400)
        async with self._camera_lock:
            key = (self.bus.state_seq, direction)
            png = self._camera.get(key)
            if png is None:
                png = await self.state.run(lambda s: render_camera(s.world, direction=direction))
                self._camera = {k: v for k, v in self._camera.items() if k[0] == key[0]} | {key: png}
        return Response(png, media_type="image/png", headers={"Cache-Control": "no-store"})

    async def image(self, request: Request) -> Response:
        """The image a `look` call returned (the last `IMAGES` are kept)."""
        png = self.bus.image(request.path_params["seq"])
        if png is None:
            return JSONResponse({"error": "no such image (only the latest are kept)"}, status_code=404)
        return Response(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})
