"""Scripts that decide from what each request carries: the repo's scripted planner over HTTP."""

from __future__ import annotations

from collections.abc import Callable

from tests.fake_llm.replies import Request, Turn


def planner_script(variant: str = "planner", *, seed: int | None = None, p: float = 0.3) -> Callable[[Request], Turn]:
    """A script in which the repo's scripted planner decides every turn, read back from HTTP."""
    from robocog.agent.policies.variants import decide

    def script(request: Request) -> Turn:
        call = decide(request.neutral(), variant, seed=seed, p=p)  # type: ignore[arg-type]
        if call.name is None:
            return Turn(text=call.text)
        return Turn(tool_calls=[(call.name, dict(call.arguments))])

    return script
