"""Consent before acting (`robocog-server --confirm-actions`): the user allows each move of the robot.

With the flag, every robot tool that moves the robot or an object (move_to, grab, place, open, close) first asks
the user through MCP elicitation: "allow once", "allow for this session" or "deny". The SDK's
resolvers carry the question on either protocol (a server-to-client request up to 2025-11-25; an
`InputRequiredResult` and a retry from 2026-07-28), so a tool only declares that it needs an answer.
A client that cannot ask its user (no elicitation capability) gets a tool error that says to run the
server without the flag, or, in a server the MCP Bundle started, to turn the extension's setting off
(`no_elicitation`).
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Hashable
from typing import Annotated, Any, Literal

from mcp.server.elicitation import AcceptedElicitation, ElicitationResult
from mcp.server.mcpserver import Context
from mcp.server.mcpserver.exceptions import ToolError
from mcp.server.mcpserver.resolve import Elicit, Resolve
from pydantic import BaseModel, Field

from robocog.server.robots.ownership import Driver
from robocog.server.tools.base import Tool

ALLOW_ONCE = "allow once"
ALLOW_SESSION = "allow for this session"
DENY = "deny"


class Decision(BaseModel):
    """What the user answered."""

    decision: Literal["allow once", "allow for this session", "deny"] = Field(
        title="Let the robot do this?",
        description="'allow for this session' stops asking until this client disconnects",
    )


NO_ELICITATION = (
    "This robot server was started with --confirm-actions: every action needs the user's consent, asked "
    "through MCP elicitation, and this client does not support elicitation. Run the server without "
    "--confirm-actions (for example, remove it from the client's server configuration), or use a client "
    "that supports elicitation."
)

#: Set by the MCP Bundle's entry point (packaging/bundle/server/main.py) to the title of the extension's
#: setting that turns --confirm-actions on: its user never typed the flag, and is told of the setting.
CONFIRM_SETTING_ENV = "ROBOCOG_CONFIRM_SETTING"


def no_elicitation() -> str:
    """What a client without elicitation is told: about the flag, or the bundle's setting when set."""
    setting = os.environ.get(CONFIRM_SETTING_ENV, "").strip()
    if not setting:
        return NO_ELICITATION
    return (
        f"This robot runs as a desktop extension with its setting '{setting}' on: every action needs the "
        "user's consent, asked through MCP elicitation, and this app does not support elicitation. Turn "
        f"'{setting}' off in the extension's settings (the app's Settings, Extensions, robocog), or use an app "
        "that supports elicitation."
    )


class ConsentGate:
    """Asks the user before `tool` runs, and remembers the drivers (`ownership.Driver`) that allowed
    actions for the rest of their session: until their connection closes, or, for a driver without
    one, while the server runs."""

    def __init__(self) -> None:
        self._allowed: set[Hashable] = set()

    def parameter(self, tool: Tool[Any]) -> inspect.Parameter:
        """The keyword parameter a tool handler declares to receive the user's answer before it runs."""
        gate = self

        async def ask(ctx: Context[Any], robot_id: str | None = None, **arguments: Any) -> Elicit[Decision] | Decision:
            state = ctx.request_context.lifespan_context
            driver = Driver.of(ctx.request_context, state.ids, handle=robot_id)
            refused = state.refusal(driver, tool.name, exclusive=True)
            if refused is not None:  # never ask the user about a call that cannot happen
                raise ToolError(refused)
            if driver.key in gate._allowed:
                return Decision(decision=ALLOW_SESSION)
            capabilities = ctx.client_capabilities
            if capabilities is None or capabilities.elicitation is None:
                raise ToolError(no_elicitation())
            shown = ", ".join(f"{k}={v!r}" for k, v in arguments.items())
            return Elicit(f"The model asks the robot to {tool.name}({shown}). Allow it?", Decision)

        keyword = inspect.Parameter.KEYWORD_ONLY
        parameters = [p.replace(kind=keyword) for p in tool.parameters]
        context = inspect.Parameter("ctx", keyword, annotation=Context[Any])
        handle = inspect.Parameter("robot_id", keyword, default=None, annotation=str | None)
        returns = Elicit[Decision] | Decision
        ask.__signature__ = inspect.Signature([context, *parameters, handle], return_annotation=returns)  # type: ignore[attr-defined]
        ask.__annotations__ = (
            {"ctx": Context[Any]}
            | {p.name: p.annotation for p in parameters}
            | {"robot_id": str | None, "return": returns}
        )
        ask.__name__ = ask.__qualname__ = f"confirm_{tool.name}"
        annotation = Annotated[ElicitationResult[Decision], Resolve(ask)]
        return inspect.Parameter("consent", keyword, annotation=annotation)

    def check(
        self, ctx: Context[Any], tool: Tool[Any], answer: ElicitationResult[Decision], handle: object = None
    ) -> None:
        """Raise a tool error unless the user allowed the action; remember "for this session"."""
        if not isinstance(answer, AcceptedElicitation) or answer.data.decision == DENY:
            raise ToolError(f"The user did not allow {tool.name}: the robot did not move. Ask the user why.")
        if answer.data.decision == ALLOW_SESSION:
            # a sessionless client is remembered by its handle (the anonymous driver cannot be: anyone is it)
            driver = Driver.of(ctx.request_context, ctx.request_context.lifespan_context.ids, handle=handle)
            if not driver.anonymous and driver.key not in self._allowed:
                self._allowed.add(driver.key)
                if driver.connection is not None:  # the session ends: ask again next time
                    driver.connection.exit_stack.callback(self._allowed.discard, driver.key)
