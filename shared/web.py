"""What the server's HTTP side and both viewers (the live one on the server, the results one in the
client) agree on: the loopback names a page may be served under, and where the pages' static files
(HTML, JavaScript, CSS; no build step) are shipped."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

#: The loopback names: a loopback-only server accepts these Host headers and Origins.
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
#: The Host values a loopback-only page accepts (Starlette's TrustedHostMiddleware wants a bare ::1 too).
LOOPBACK_HOSTS = [*LOOPBACK_NAMES, "::1"]
#: How long the server keeps an idle HTTP connection open (uvicorn's default is 5 s). A model's turn
#: between two tool calls takes seconds to a minute: at 5 s, most calls of an attempt paid for a new
#: TCP connection (and the server for accepting it).
SERVER_KEEP_ALIVE_S = 75
#: How long a client keeps an idle connection in its pool (httpx's default is 5 s): less than the
#: server's, so a client never sends a request on a connection the server is closing.
CLIENT_KEEP_ALIVE_S = SERVER_KEEP_ALIVE_S - 15
#: The static files of both viewers (robocog.assets.viewer).
VIEWER_STATIC = Path(str(files("robocog.assets") / "viewer"))
