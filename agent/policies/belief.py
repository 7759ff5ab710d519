"""What the scripted planner reads from the conversation: the episode's tool calls, its belief
about the world, and the task's goals.

Like a model, the planner is stateless: every turn it rebuilds all of this from the messages.
"""

from __future__ import annotations

import functools
import json
import re
from collections import Counter, deque
from dataclasses import dataclass, field, replace
from typing import Any

import yaml

from robocog.agent.client.eval_protocols import task_of
from robocog.assets import ASSETS_DIR

UNGRASPABLE_NOTE = "Objects that cannot be grasped:"


@dataclass(frozen=True)
class Goal:
    location: str
    position: str | None = None  # None: any free position of the location


@dataclass
class Belief:
    """What the planner believes, from its last look around and the results since."""

    location: str = ""
    holding: str | None = None
    neighbours: dict[str, list[str]] = field(default_factory=dict)
    positions: dict[str, list[str]] = field(default_factory=dict)  # location -> position names, in order
    occupant: dict[tuple[str, str], str | None] = field(default_factory=dict)
    where: dict[str, tuple[str, str | None]] = field(default_factory=dict)  # object -> (location, position)
    stale: bool = False

    @classmethod
    def from_look(cls, look: dict[str, Any]) -> Belief:
        b = cls(location=look.get("location", ""), holding=look.get("holding"))
        for loc in look.get("locations", []):
            name = loc["name"]
            b.neighbours[name] = list(loc.get("neighbours", []))
            b.positions[name] = [p["name"] for p in loc.get("place_positions", [])]
            for p in loc.get("place_positions", []):
                b.occupant[(name, p["name"])] = p.get("occupied_by")
                if p.get("occupied_by"):
                    b.where[p["occupied_by"]] = (name, p["name"])
            for obj in loc.get("objects", []):
                b.where.setdefault(obj, (name, None))
        return b

    def copy(self) -> Belief:
        return Belief(
            self.location,
            self.holding,
            self.neighbours,
            self.positions,
            dict(self.occupant),
            dict(self.where),
            self.stale,
        )

    def hops_from(self, start: str) -> dict[str, int]:
        """Breadth-first distances on the map."""
        dist = {start: 0}
        queue = deque([start])
        while queue:
            node = queue.popleft()
            for nxt in self.neighbours.get(node, []):
                if nxt not in dist:
                    dist[nxt] = dist[node] + 1
                    queue.append(nxt)
        return dist

    def free_positions(self, location: str) -> list[str]:
        return [p for p in self.positions.get(location, []) if self.occupant.get((location, p)) is None]

    def objects(self) -> list[str]:
        """Every object seen, the held one included."""
        return list(self.where) + ([self.holding] if self.holding and self.holding not in self.where else [])


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


def _parse_json(content: Any) -> dict[str, Any] | None:
    if content is None:
        return None
    try:
        value = json.loads(_plain(content))
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) else None


def _plain(content: Any) -> str:
    """A message's content as text (content blocks joined)."""
    if isinstance(content, list):  # content blocks
        return "".join(str(b.get("text", "")) for b in content if isinstance(b, dict))
    return str(content or "")


def read_history(messages: list[Any]) -> History:
    """The task, every tool call with its result, and the memories found, from the conversation."""
    msgs = [as_dict(m) for m in messages]
    asked = [(i, task_of(_plain(m.get("content")))) for i, m in enumerate(msgs) if m.get("role") == "user"]
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
            args = _parse_json(fn.get("arguments") or "{}") or {}
            result = _parse_json(results.get(tc.get("id")))
            is_error = result is None or result.get("status") == "failure"
            calls.append(PastCall(str(fn.get("name")), args, result, is_error))
            if fn.get("name") == "search_memory" and result:
                memories.extend(result.get("results", []))
    return History(task=task, calls=calls, memories=memories)


def current_belief(history: History) -> tuple[Belief | None, Belief | None]:
    """(belief at the first look around, belief now) — None before any look around."""
    first: Belief | None = None
    belief: Belief | None = None
    for call in history.calls:
        name, args, result, is_error = call.name, call.arguments, call.result, call.is_error
        if name == "look_around" and result and not is_error:
            belief = Belief.from_look(result)
            first = first or belief.copy()
            continue
        if belief is None or result is None:
            continue
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
        elif name == "place" and result.get("error") == "position_occupied":
            key = (result.get("location"), result.get("position"))
            if belief.occupant.get(key) is None:
                belief.occupant[key] = "(something)"
        elif name == "place" and result.get("error") == "place_failed":
            belief.holding = None
            belief.stale = True
    return first, belief


# --- understanding the task ----------------------------------------------------------------------
#
# A task names objects (by name, by a description, or by where they are) and where they should end
# up. `understand` turns it into goals, and says up front when the goals cannot be met.


@dataclass(frozen=True)
class Request:
    """What a task asks for: where each object should end up."""

    family: str  # put_away, swap, bring or rearrange: a label for the plan note
    goals: dict[str, Goal]
    all_items: bool = False  # "put away all the items": an object that cannot be grasped is no item
    problem: str | None = None  # why the goals cannot be met, seen before acting
    recall: str | None = None  # an object whose earlier place only memory knows


_PREPOSITION = re.compile(r"\b(?:onto|into|to|on|in|at)\b")
_ALL_ITEMS = re.compile(r"^(?:all (?:of )?)?(?:the )?(?:items|objects|things)$|^everything$")
_RELATION = re.compile(r"^(?:item|object|thing|one) (?:on|at|in|from) (.+)$")
_TRANSPORT = re.compile(r"^(?:please )?(put|place|set|tidy|clear|bring|take|carry|move|get)\b")
_PUTTING = {"put", "place", "set", "tidy", "clear"}


def _clean(text: str) -> str:
    """Lower case, single spaces, no surrounding punctuation, no leading article."""
    text = re.sub(r"\s+", " ", text.lower()).strip(" .!?;:,")
    return re.sub(r"^(?:the|a|an) ", "", text)


_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@functools.cache
def scene_descriptions() -> dict[str, tuple[str, ...]]:
    """Object name -> the descriptions the scenes in assets/scenes give it (world knowledge the
    planner, as the suite's oracle, may use to resolve "the drinking vessel")."""
    found: dict[str, list[str]] = {}
    for path in sorted((ASSETS_DIR / "scenes").glob("*.yaml")):
        try:
            data = yaml.load(path.read_text(encoding="utf-8"), Loader=_LOADER)
        except (OSError, UnicodeDecodeError, yaml.YAMLError):
            continue
        objects = data.get("objects") if isinstance(data, dict) else None
        for obj in objects if isinstance(objects, list) else []:
            if isinstance(obj, dict) and isinstance(obj.get("name"), str):
                said = obj.get("descriptions") or []
                found.setdefault(obj["name"], []).extend(str(d) for d in said if isinstance(said, list))
    return {name: tuple(dict.fromkeys(_clean(d) for d in said)) for name, said in found.items()}


def _called(obj: str) -> set[str]:
    """What an object may be called: its name (with spaces for underscores) and its descriptions."""
    name = obj.lower()
    return {name, name.replace("_", " "), *scene_descriptions().get(obj, ())}


def _match_location(text: str, locations: list[str]) -> str | None:
    """The location named in `text`: a full name, else the one whose last word is mentioned."""
    low = text.lower()
    for name in sorted(locations, key=len, reverse=True):
        if re.search(rf"\b{re.escape(name.lower())}\b", low):
            return name
    words = set(re.findall(r"[a-z]+", low))
    hits = [n for n in locations if n.lower().split()[-1] in words]
    return hits[0] if len(hits) == 1 else (sorted(hits, key=len)[0] if hits else None)


def _spot(text: str, first: Belief) -> Goal | None:
    """The location a phrase names, with the place position it names (if any)."""
    location = _match_location(text, list(first.neighbours))
    if location is None:
        return None
    rest = text.lower().replace(location.lower(), " ")
    position = next(
        (p for p in first.positions.get(location, []) if re.search(rf"\b{re.escape(p.lower())}\b", rest)), None
    )
    return Goal(location, position)


def _by_relation(text: str, first: Belief) -> tuple[str | None, str | None]:
    spot = _spot(text, first)
    if spot is None:
        return None, f"there is no place called '{text}'"
    if spot.position is not None:
        found = first.occupant.get((spot.location, spot.position))
        named = f"{spot.location} / {spot.position}"
        return (found, None) if found else (None, f"nothing is on {named}")
    there = [o for o, (loc, _) in first.where.items() if loc == spot.location]
    if len(there) == 1:
        return there[0], None
    return None, (f"nothing is at {spot.location}" if not there else f"several things are at {spot.location}")


def resolve_object(phrase: str, first: Belief) -> tuple[str | None, str | None]:
    """(the object a phrase names, None), or (None, why it names none): by name, by a description,
    or by a relation ("the item on Kitchen Shelf top")."""
    text = _clean(phrase)
    relation = _RELATION.match(text)
    if relation:
        return _by_relation(relation.group(1), first)
    singular = text[:-1] if text.endswith("s") and not text.endswith("ss") else text
    hits = [o for o in first.objects() if {text, singular} & _called(o)]
    if len(hits) == 1:
        return hits[0], None
    if hits:
        return None, f"'{text}' could be the {' or the '.join(sorted(hits))}"
    return None, f"there is no {text} here"


def _object_phrase(phrase: str, first: Belief) -> tuple[str | None, str | None]:
    """An object reference that may trail a phrase about where it is ("the cube in the shelf")."""
    found, problem = resolve_object(phrase, first)
    if found or _RELATION.match(_clean(phrase)):
        return found, problem
    for cut in reversed(list(_PREPOSITION.finditer(phrase))):
        found, problem = resolve_object(phrase[: cut.start()], first)
        if found:
            return found, None
    return None, problem


def _destination_split(text: str, first: Belief) -> tuple[list[str], Goal | None, str | None]:
    """Split "<objects> <preposition> <place>": (object phrases, where to, why not).

    The first split whose objects all resolve wins (so "the item on Kitchen Shelf top to the
    Living Room" splits at "to"); failing that, the last split that names a place, for its problem."""
    fallback: tuple[list[str], Goal | None, str | None] = ([], None, None)
    for cut in _PREPOSITION.finditer(text):
        phrases = [p for p in (_clean(x) for x in re.split(r",|\band\b", text[: cut.start()])) if p]
        where = _spot(text[cut.end() :], first)
        if where is None or not phrases:
            continue
        if (len(phrases) == 1 and _ALL_ITEMS.match(phrases[0])) or all(resolve_object(p, first)[0] for p in phrases):
            return phrases, where, None
        fallback = (phrases, where, None)
    if fallback[1] is None:
        tail = _PREPOSITION.split(text, maxsplit=1)
        fallback = ([], None, f"there is no place called '{_clean(tail[-1])}'" if len(tail) > 1 else None)
    return fallback


def _named(phrases: list[str], first: Belief) -> tuple[list[str], list[str]]:
    """The objects the phrases name, and the problems of those that name none."""
    found = [resolve_object(p, first) for p in phrases]
    return list(dict.fromkeys(o for o, _ in found if o)), [why for o, why in found if o is None and why]


def _transport(verb: str, text: str, first: Belief) -> Request | None:
    phrases, where, problem = _destination_split(re.sub(r"\baway\b", " ", text), first)
    if problem:
        return Request("bring", {}, problem=problem)
    if where is None:
        return None
    family = "put_away" if verb in _PUTTING else "bring"
    if len(phrases) == 1 and _ALL_ITEMS.match(phrases[0]):
        items = [o for o in first.objects() if first.where.get(o, ("", None))[0] != where.location]
        return Request("put_away", {o: where for o in items}, all_items=True)
    objects, problems = _named(phrases, first)
    return Request(family, {o: where for o in objects}, problem="; ".join(problems) or None)


def _swap(text: str, first: Belief) -> Request | None:
    parts = re.split(r"\band\b", text, maxsplit=1)
    if len(parts) != 2:
        return None
    found = [_object_phrase(p, first) for p in parts]
    problems = [why for o, why in found if o is None and why]
    if problems:
        return Request("swap", {}, problem="; ".join(problems))
    a, b = (str(o) for o, _ in found)
    loose = [o for o in (a, b) if not first.where.get(o, ("", None))[1]]
    if loose or a == b:
        same = f"'{_clean(parts[0])}' and '{_clean(parts[1])}' are the same object"
        why = f"the {loose[0]} is not on a place position" if loose else same
        return Request("swap", {}, problem=why)
    return Request("swap", {a: Goal(*first.where[b]), b: Goal(*first.where[a])})


def _arrange(text: str, first: Belief) -> Request:
    goals: dict[str, Goal] = {}
    problems: list[str] = []
    for clause in (c for c in re.split(r",|;|\band\b", text) if c.strip()):
        phrases, where, problem = _destination_split(clause, first)
        objects, missing = _named(phrases, first)
        problems += [problem] if problem else missing
        if where is not None:
            goals |= {o: where for o in objects}
    return Request("rearrange", goals, problem="; ".join(problems) or None)


def _capacity(goals: dict[str, Goal], first: Belief) -> str | None:
    """Why the goals cannot all fit where they should go, if they cannot."""
    named = Counter((g.location, g.position) for g in goals.values() if g.position)
    clash = next((spot for spot, n in named.items() if n > 1), None)
    if clash:
        return f"{named[clash]} objects are to go on {clash[0]} / {clash[1]}"
    for location in dict.fromkeys(g.location for g in goals.values()):
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


def _when(memory: dict[str, Any]) -> str:
    return str(memory.get("when") or "")


def recall_origin(obj: str, memories: list[dict[str, Any]]) -> Goal | None:
    """Where `obj` was before the latest remembered task moved it (the planner's reports say "the mug
    is on Front Door / floor (it was on Kitchen Shelf / bottom)"); None when that task did not say."""
    said = re.compile(rf"\bthe {re.escape(obj)} is on [^;()]+ \(it was on ([^/;()]+?) / ([^;()]+?)\)", re.IGNORECASE)
    latest = max(memories, key=_when, default=None)
    found = said.search(str(latest.get("summary", ""))) if latest else None
    return Goal(found.group(1).strip(), found.group(2).strip()) if found else None


def _put_back(text: str, first: Belief, memories: list[dict[str, Any]]) -> Request:
    found, problem = _object_phrase(text, first)
    if found is None:
        return Request("put_back", {}, problem=problem)
    # A last task that did not mention the object left it where it was.
    origin = recall_origin(found, memories) or (
        Goal(*first.where[found]) if memories and found in first.where else None
    )
    if origin is None or origin.position is None:
        return Request("put_back", {}, recall=found, problem=f"I do not remember where the {found} was")
    return Request("put_back", {found: origin}, recall=found)


def understand(
    task: str, first: Belief, avoid: set[str], memories: list[dict[str, Any]] | None = None
) -> Request | None:
    """What the task asks for, or None when the planner does not know how to do such a task.

    `avoid`: objects known (from memory) not to be graspable: not items to put away, and a task that
    needs one of them cannot be done. `memories`: what search_memory found (where things were)."""
    text = _clean(task)
    swap = re.match(r"^swap (.+)$", text)
    arrange = re.match(r"^(?:re)?arrange\b[^:]*:(.+)$", text)
    back = re.match(r"^(?:please )?(?:put|bring|take|move|return) (.+?) back\b", text)
    transport = _TRANSPORT.match(text)
    if back:
        request: Request | None = _put_back(back.group(1), first, memories or [])
    elif swap:
        request = _swap(swap.group(1), first)
    elif arrange:
        request = _arrange(arrange.group(1), first)
    elif transport:
        request = _transport(transport.group(1), text[transport.end() :], first)
    else:
        return None
    if request is None or request.problem or request.all_items:
        if request is not None and request.all_items:
            request = replace(request, goals={o: g for o, g in request.goals.items() if o not in avoid})
        return request
    if not request.goals:
        return None
    known = sorted(o for o in request.goals if o in avoid)
    if known:
        return replace(request, problem=f"the {', '.join(known)} cannot be grasped (an earlier task found this)")
    return replace(request, problem=_capacity(request.goals, first))


def remembered_ungraspable(memories: list[dict[str, Any]]) -> set[str]:
    """Objects that past task reports say cannot be grasped."""
    found: set[str] = set()
    for m in memories:
        match = re.search(re.escape(UNGRASPABLE_NOTE) + r"\s*([\w ,\-]+)\.", m.get("summary", ""))
        if match:
            found.update(x.strip() for x in match.group(1).split(",") if x.strip())
    return found
