"""What the scripted planner reads from the conversation: the episode's tool calls, its belief
about the world (`belief.Belief`), and the task's goals.

Like a model, the planner is stateless: every turn it rebuilds all of this from the messages. What
it reads of one message's text does not change from turn to turn, so that reading is remembered by
the text (a bounded cache): a turn parses only the messages new since the last one.
"""

from __future__ import annotations

import functools
import json
import re
from collections import Counter
from collections.abc import Hashable
from dataclasses import dataclass, field, replace
from typing import Any

from robocog.agent.families import prompt_readers
from robocog.agent.families.reading import Goal, Request, clean
from robocog.agent.policies import sightings
from robocog.agent.policies.belief import UNGRASPABLE_NOTE, Belief
from robocog.agent.policies.memo import Kept, frozen
from robocog.agent.study_protocols import task_of


@dataclass(frozen=True)
class Call:
    """The next tool call the planner wants, or a plain text answer when `name` is None."""

    name: str | None
    arguments: dict[str, Any] = field(default_factory=dict)
    text: str = ""


@dataclass(frozen=True)
class PastCall:
    """A tool call made earlier in the episode, with its result (None when it was not JSON)."""

    name: str
    arguments: dict[str, Any]
    result: dict[str, Any] | None
    is_error: bool


@dataclass
class History:
    """The episode so far, read from the conversation."""

    task: str
    calls: list[PastCall]
    memories: list[dict[str, Any]]


# --- reading the conversation --------------------------------------------------------------------


def as_dict(message: Any) -> dict[str, Any]:
    """A chat message (a dict, or a LiteLLM/pydantic object) as a plain dict."""
    if isinstance(message, dict):
        return message
    if hasattr(message, "model_dump"):
        dumped: dict[str, Any] = message.model_dump()
        return dumped
    return dict(message)


#: Texts whose reading is remembered (tool calls with their results, user messages): more than the
#: episodes a study keeps in flight at once hold (when they are more, they are read again).
READINGS_KEPT = 4096


@functools.lru_cache(maxsize=READINGS_KEPT)
def _past_call(name: str, arguments: str, result: str | None) -> PastCall:
    """A tool call read from its name, the text of its arguments and that of its result (None: no
    result). The same `PastCall` for the same texts: the planner only reads it (never changes it)."""
    read = None if result is None else _parse_json(result)
    if name == "look_around" and read is not None:  # its belief is read once too (`_looked`)
        _LOOKS[id(read)] = (read, None)
    return PastCall(name, _parse_json(arguments) or {}, read, read is None or read.get("status") == "failure")


def _parse_json(text: str) -> dict[str, Any] | None:
    """The JSON object a text holds, None when it holds none."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) else None


@functools.lru_cache(maxsize=READINGS_KEPT)
def _task_of(text: str) -> str:
    """The task a user message's text gives (`robocog.agent.study_protocols.task_of`)."""
    return task_of(text)


def _plain(content: Any) -> str:
    """A message's content as text (content blocks joined)."""
    if isinstance(content, list):  # content blocks
        return "".join(str(b.get("text", "")) for b in content if isinstance(b, dict))
    return str(content or "")


def read_history(messages: list[Any]) -> History:
    """The task, every tool call with its result, and the memories found, from the conversation."""
    msgs = [as_dict(m) for m in messages]
    asked = [(i, _task_of(_plain(m.get("content")))) for i, m in enumerate(msgs) if m.get("role") == "user"]
    task = asked[-1][1] if asked else ""
    # The current task began at the first of the trailing user messages that carry it: a conversation
    # may hold earlier tasks (the paper's protocol runs T2 after T1 in one conversation).
    begin = 0
    for i, asked_task in reversed(asked):
        if asked_task != task:
            break
        begin = i
    msgs = msgs[begin:]
    results: dict[Any, Any] = {m.get("tool_call_id"): m.get("content") for m in msgs if m.get("role") == "tool"}
    calls: list[PastCall] = []
    memories: list[dict[str, Any]] = []
    for m in msgs:
        if m.get("role") != "assistant":
            continue
        for tc in m.get("tool_calls") or []:
            tc = as_dict(tc)
            fn = as_dict(tc.get("function") or {})
            result = results.get(tc.get("id"))
            text = None if result is None else _plain(result)
            call = _past_call(str(fn.get("name")), _plain(fn.get("arguments") or "{}"), text)
            calls.append(call)
            if fn.get("name") == "search_memory" and call.result:
                memories.extend(call.result.get("results", []))
    return History(task=task, calls=calls, memories=memories)


#: The look_around results `_past_call` read, by id: the result (kept, so no other object has its id)
#: and, once read, the belief it gives (`_looked`).
_LOOKS: Kept[int, tuple[dict[str, Any], Belief | None]] = Kept(1024)


def _looked(look: dict[str, Any]) -> Belief:
    """`Belief.from_look(look)`: for a result of `_past_call` (shared, never changed), read once, as
    the planner reads an episode's looks again every turn. Each call gets a belief of its own to change
    (its lists of neighbours and positions are shared: they are replaced, never changed)."""
    known = _LOOKS.get(id(look))
    if known is None or known[0] is not look:  # not a result read here
        return Belief.from_look(look)
    read = known[1]
    if read is None:
        read = Belief.from_look(look)
        _LOOKS[id(look)] = (look, read)
    belief = read.copy()
    belief.neighbours, belief.positions = dict(read.neighbours), dict(read.positions)
    return belief


def current_belief(history: History) -> tuple[Belief | None, Belief | None]:
    """(belief at the first look around, belief now) — None before any look around."""
    first: Belief | None = None
    belief: Belief | None = None
    beyond_reach: set[tuple[Any, Any]] = set()  # positions a place could not reach: a later look shows
    for call in history.calls:  # them free, but they stay beyond the arm for the rest of the episode
        name, args, result, is_error = call.name, call.arguments, call.result, call.is_error
        if name == "look_around" and result and not is_error:
            seen = _looked(result)
            belief = seen if belief is None else sightings.merge(belief, result, seen)
            first = first or belief.copy()
            continue
        if belief is None or result is None:
            continue
        sightings.vanished(belief, name, result)
        if name == "move_to":
            belief.location = result.get("location", belief.location)
        elif name == "grab" and not is_error:
            obj: str | None = result.get("object") or args.get("object")
            where = belief.where.pop(obj, None) if obj is not None else None
            if where and where[1]:
                belief.occupant[(where[0], where[1])] = None
            belief.holding = obj
        elif name == "grab" and result.get("error") == "out_of_reach":
            belief.stale = True  # not where it was believed to be: look again
        elif name == "place" and not is_error:
            key = (result["location"], result["position"])
            placed: str | None = result.get("object")
            belief.occupant[key] = placed
            if placed is not None:  # a successful place names the object
                belief.where[placed] = key
            belief.holding = None
        elif name == "place" and (shut := sightings.closed_over(result)) is not None:
            belief.closed.add(shut)  # inside a container that is closed (someone shut it?): open it first
        elif name == "place" and result.get("error") in ("position_occupied", "out_of_reach"):
            key = (result.get("location"), result.get("position"))  # taken, or beyond the arm: try another
            if belief.occupant.get(key) is None:
                belief.occupant[key] = "(something)"
            if result.get("error") == "out_of_reach" and "move_to(" not in str(result.get("message", "")):
                beyond_reach.add(key)
        elif name == "place" and result.get("error") == "place_failed":
            belief.holding = None
            belief.stale = True
        elif name in ("open", "close"):
            sightings.operated(belief, result, opened=name == "open")
    if belief is not None:
        for key in beyond_reach:
            if belief.occupant.get(key) is None:
                belief.occupant[key] = "(beyond the arm)"
    return first, belief


# --- understanding the task ----------------------------------------------------------------------
#
# A task names objects (by name, by a description, or by where they are) and where they should end
# up. `understand` turns it into goals with the prompt readers the task families register
# (`robocog.agent.families`), and says up front when the goals cannot be met.


def _capacity(goals: dict[str, Goal], first: Belief) -> str | None:
    """Why the goals cannot all fit where they should go, if they cannot."""
    named = Counter((g.location, g.position) for g in goals.values() if g.position)
    clash = next((spot for spot, n in named.items() if n > 1), None)
    if clash:
        return f"{named[clash]} objects are to go on {clash[0]} / {clash[1]}"
    for location in dict.fromkeys(g.location for g in goals.values()):
        if location in first.containers.values():
            continue  # its positions show once it is opened
        wanted = [o for o, g in goals.items() if g.location == location and g.position is None]
        usable = [p for p in first.positions.get(location, []) if (location, p) not in named]
        if wanted and not first.positions.get(location):
            return f"there is no place position at {location}"
        if len(wanted) > len(usable):
            if not usable:
                return f"no free place position at {location}"
            return f"{len(wanted)} objects to place at {location}, which has {len(usable)} place position" + (
                "s" if len(usable) > 1 else ""
            )
    return None


def understand(
    task: str, first: Belief, avoid: set[str], memories: list[dict[str, Any]] | None = None
) -> Request | None:
    """What the task asks for, or None when the planner does not know how to do such a task.

    `avoid`: objects known (from memory) not to be graspable: not items to put away, and a task that
    needs one of them cannot be done. `memories`: what search_memory found (where things were).

    The task families' prompt readers are asked in their registered order (put back, swap, arrange,
    then transport: `robocog.agent.families.registry`); the first whose pattern matches the cleaned
    task reads it, and its answer stands.

    The answer depends on nothing else, and the planner asks again every turn: the latest answers are
    remembered (the same `Request`, which nobody changes)."""
    key = (task, first.key(), frozenset(avoid), frozen(memories or []))
    try:
        known = _UNDERSTOOD.get(key, _UNREAD)
    except TypeError:  # something believed or remembered that is no key: read afresh
        return _understand(task, first, avoid, memories or [])
    if known is not _UNREAD:
        return known
    request = _UNDERSTOOD[key] = _understand(task, first, avoid, memories or [])
    return request


#: Tasks understood, by all that their reading depends on (`understand`).
_UNDERSTOOD: Kept[Hashable, Request | None] = Kept(256)
_UNREAD = Request("", {})


def _understand(task: str, first: Belief, avoid: set[str], memories: list[dict[str, Any]]) -> Request | None:
    text = clean(task)
    found = next(((r, m) for r in prompt_readers() if (m := r.pattern.match(text)) is not None), None)
    if found is None:
        return None
    reader, match = found
    request = reader.read(match, first, memories)
    if request is None or request.problem or request.all_items:
        if request is not None and request.all_items:
            request = replace(request, goals={o: g for o, g in request.goals.items() if o not in avoid})
        return request
    if not request.goals:
        return None
    if request.explore:  # what the first look did not show, the search will
        return request
    if first.partial and sightings.out_of_sight(request.goals, first):  # partial observation: search first
        return replace(request, explore=True)
    known = sorted(o for o in request.goals if o in avoid)
    if known:
        return replace(request, problem=f"the {', '.join(known)} cannot be grasped (an earlier task found this)")
    return replace(request, problem=_capacity(request.goals, first))


def remembered_ungraspable(memories: list[dict[str, Any]]) -> set[str]:
    """Objects that past task reports say cannot be grasped."""
    said = (re.search(re.escape(UNGRASPABLE_NOTE) + r"\s*([\w ,\-]+)\.", m.get("summary", "")) for m in memories)
    return {x.strip() for match in said if match for x in match.group(1).split(",") if x.strip()}
