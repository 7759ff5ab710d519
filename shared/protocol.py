"""Names both sides of the MCP connection agree on, beyond the tools' own schemas."""

import re

#: `_meta` key a client sets on tool calls to name the model driving the robot; end_task stores it.
MODEL_META_KEY = "robocog/model"

#: `_meta` key of the driver id: the server issues one to an HTTP client without an MCP session
#: (protocol 2026-07-28 and later) in the result of its first call that needs a robot, and the client
#: sends it back on every later call; the robot is held by one driver at a time (server/robots/ownership.py).
DRIVER_META_KEY = "robocog/driver"

#: The argument every robot tool and control takes on a client without a session (MCP 2026-07-28 over
#: HTTP): the robot handle the server minted (SEP-2567; server/robots/ownership.py). A client never offers it to
#: a model: robocog's own client passes the handle itself (or in `_meta["robocog/driver"]`, an alias).
ROBOT_ID_ARG = "robot_id"

#: Words every "the fleet is full" error of a server holds (a tool or resource error, a 503 at initialize):
#: a client reports it as the server's answer and stops, never as the model's failure.
FLEET_FULL = "robots of this server are driven by other sessions"

#: Words every error of a server whose episodic memory cannot be read or written holds (a full disk, a
#: read-only or removed database), followed by the reason: a client reports it as the server's failure
#: (the attempt errs, with the reason in its row), never as the model's, and never retries it.
MEMORY_FAILED = "the robot's episodic memory failed"

#: The eval profile's controls for harnesses: a client never offers them to the model it drives.
CONTROL_TOOLS = frozenset({"reset_world", "begin_task", "check_task", "clear_memory"})

#: The robot app (an MCP App, SEP-1865): its page's URI and MIME type, and the tools meant for it alone
#: (`_meta.ui.visibility: ["app"]`): a client never offers them to a model.
APP_URI = "ui://robocog/robot"
APP_MIME_TYPE = "text/html;profile=mcp-app"
APP_TOOLS = frozenset({"robot_view"})

#: The eight robot tools of the paper, in its order: what a text-only model is offered (robocog's own
#: client; robocog.inspect). The server's ROBOT_TOOLS are these, the VISION_TOOLS and the FURNITURE_TOOLS (a
#: test holds it).
PAPER_TOOLS: tuple[str, ...] = (
    "look_around",
    "move_to",
    "grab",
    "place",
    "add_to_scratchpad",
    "view_scratchpad",
    "end_task",
    "search_memory",
)

#: Tools whose answer is a picture: a client offers them only to a model that takes images (robocog's
#: `--vision`), and never under the paper's protocol, whose models had the eight tools of the paper.
VISION_TOOLS = frozenset({"look"})

#: Tools that open and close furniture (drawers, cabinets, fridges): the `robocog` protocol offers them,
#: the paper's never does (its models had the eight tools of the paper).
FURNITURE_TOOLS = frozenset({"open", "close"})

#: The version of the published MCP contract (assets/contract/, CHANGELOG.md there). The server announces
#: it in its instructions as "MCP contract X.Y"; `robocog contract` reads it back from there.
CONTRACT_VERSION = "4.3"

#: The contract version in a server's instructions: "MCP contract 1.0", "contract 2.3".
CONTRACT_VERSION_PATTERN = re.compile(r"\bcontract\s+v?(\d+(?:\.\d+)+)\b", re.IGNORECASE)
