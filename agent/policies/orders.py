"""The planner's plan in other orders of calls: robocog-v2.1's perturbations are set off by the world's
state, so an agent meets them whatever order it calls its tools in, and these policies prove it (the
suite's bench runs all three on every recovery instance): the planner; `Verbose`, which reads its
memory, its scratchpad and looks first, and looks again before every robot action; `Lean`, which never
looks again unless a call failed. Each is the planner (`robocog.agent.policies.planner`) with its
order of calls changed, nothing else.
"""

from __future__ import annotations

from robocog.agent.policies.history import Call, History, PastCall
from robocog.agent.policies.planner import ROBOT_ACTIONS, Episode, Planner


class Verbose(Planner):
    """The planner in a verbose order: it reads its memory, then its scratchpad, then looks, and looks
    around again before every robot action."""

    def __call__(self, history: History) -> Call:
        names = {c.name for c in history.calls}
        if "search_memory" not in names:
            return Call("search_memory", {"query": history.task.strip()})
        if "view_scratchpad" not in names:
            return Call("view_scratchpad")
        call = super().__call__(history)
        if call.name in ROBOT_ACTIONS and history.calls[-1].name != "look_around":
            return Call("look_around")
        return call


class Lean(Planner):
    """The planner in a lean order: look, move, grab, move, place, end. It neither searches its memory
    nor writes a plan (but for a task that needs what memory holds), never looks again unless a call
    failed (an announcement of a change it reads, but does not look for), and ends without a last look.
    Under partial observation it looks at each place it has not seen, as a search must, and so into a
    container it has just opened."""

    def prepares(self, task: str) -> bool:
        return "back" in task.lower().split()  # only a task that needs what memory holds

    def looks_again(self, calls: list[PastCall]) -> bool:
        # After a failure; and into a container it just opened, a place it has not seen.
        return bool(calls) and (calls[-1].is_error or calls[-1].name == "open")

    def conclude(self, episode: Episode) -> Call:
        return episode.report()
