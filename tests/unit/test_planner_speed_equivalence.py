"""The scripted planner reads the whole conversation again every turn; what it keeps between turns
(the readings of texts that have not changed, the beliefs its looks give, the tasks it understood, the
map's hops, the size of the messages as JSON, the search's estimates) must answer exactly as working
it out afresh would: these tests compare the two."""

from __future__ import annotations

import copy
import json
from collections import deque
from typing import Any

from robocog.agent.policies.belief import Belief, Goal
from robocog.agent.policies.history import History, PastCall, current_belief, read_history, understand
from robocog.agent.policies.memo import Kept, frozen
from robocog.agent.policies.offline import prompt_chars
from robocog.agent.policies.variants import decide
from robocog.agent.symbolic.bounds import carrying_drives, drives_along
from robocog.agent.symbolic.rearrangement import HELD, Rearrangement, rearrangement

TASK = "Put the mug on the Front Door."
LOOK: dict[str, Any] = {
    "status": "success",
    "message": "The robot is at Hall.",
    "location": "Hall",
    "holding": None,
    "locations": [
        {
            "name": "Hall",
            "neighbours": ["Kitchen", "Front Door"],
            "objects": ["cube"],
            "place_positions": [{"name": "floor", "occupied_by": "cube"}, {"name": "bench", "occupied_by": None}],
        },
        {
            "name": "Kitchen",
            "neighbours": ["Hall"],
            "objects": ["mug", "box"],
            "place_positions": [{"name": "top", "occupied_by": "mug"}, {"name": "middle", "occupied_by": "box"}],
        },
        {
            "name": "Front Door",
            "neighbours": ["Hall"],
            "objects": [],
            "place_positions": [{"name": "floor", "occupied_by": None}],
        },
    ],
}


def conversation(look: dict[str, Any] = LOOK) -> list[dict[str, Any]]:
    """A conversation as the agent loop writes it: the task, then calls with their results."""
    messages: list[dict[str, Any]] = [{"role": "system", "content": "You are a robot."}]
    messages.append({"role": "user", "content": TASK})
    calls = [
        ("search_memory", {"query": TASK}, {"status": "success", "message": "None.", "results": []}),
        ("look_around", {}, look),
        ("move_to", {"location": "Kitchen"}, {"status": "success", "message": "Here.", "location": "Kitchen"}),
    ]
    for i, (name, arguments, result) in enumerate(calls, 1):
        call = {"id": f"call_{i}", "type": "function", "function": {"name": name, "arguments": json.dumps(arguments)}}
        messages.append({"role": "assistant", "content": None, "tool_calls": [call]})
        messages.append({"role": "tool", "tool_call_id": f"call_{i}", "content": json.dumps(result)})
    return messages


def afresh(messages: list[dict[str, Any]]) -> History:
    """The episode's calls, parsed afresh (new objects, nothing shared with earlier turns)."""
    results = {m["tool_call_id"]: json.loads(m["content"]) for m in messages if m["role"] == "tool"}
    calls = [
        PastCall(name, json.loads(tc["function"]["arguments"]), result, result.get("status") == "failure")
        for m in messages
        if m["role"] == "assistant"
        for tc in m["tool_calls"]
        for name, result in [(tc["function"]["name"], results[tc["id"]])]
    ]
    return History(TASK, calls, [])


def test_prompt_chars_is_each_message_as_json_summed() -> None:
    class Reply:  # an object the loop might hold, written as its text
        def __str__(self) -> str:
            return "a reply"

    messages: list[Any] = [
        *conversation(),
        {"role": "user", "content": [{"type": "text", "text": "café ✓"}]},
        {"role": "tool", "tool_call_id": "call_9", "content": "1", "seen": 1},
        {"role": "tool", "tool_call_id": "call_9", "content": "1", "seen": True},
        {"role": "tool", "tool_call_id": None, "content": 'quote " and \\ and \n'},
        Reply(),
    ]
    for n in range(len(messages) + 1):
        part = messages[:n]
        assert prompt_chars(part) == sum(len(json.dumps(m, default=str)) for m in part)
    grown: list[Any] = []  # one conversation, growing as the loop grows it: only new messages are measured
    for m in messages:
        grown.append(m)
        assert prompt_chars(grown) == sum(len(json.dumps(m, default=str)) for m in grown)
    grown[1] = {**grown[1], "content": "Put the cube on the Kitchen."}  # replaced: measured again
    assert prompt_chars(grown) == sum(len(json.dumps(m, default=str)) for m in grown)
    del grown[2]  # taken out: measured again
    assert prompt_chars(grown) == sum(len(json.dumps(m, default=str)) for m in grown)


def test_the_history_is_what_the_messages_say_now() -> None:
    messages = conversation()
    assert read_history(messages) == afresh(messages) == read_history(copy.deepcopy(messages))
    messages[-1]["content"] = json.dumps({"status": "failure", "error": "blocked", "message": "Blocked."})
    history = read_history(messages)
    assert history == afresh(messages) and history.calls[-1].is_error  # a changed result is read again


def test_a_look_gives_each_turn_the_belief_it_gives_afresh_and_a_belief_of_its_own() -> None:
    messages = conversation()
    expected = current_belief(afresh(messages))
    first, now = current_belief(read_history(messages))
    assert (first, now) == expected and now is not None and now.location == "Kitchen"
    now.where.pop("mug")  # what the planner does to its belief within a turn
    now.neighbours["Hall"] = []
    now.positions["Kitchen"] = []
    now.closed.add("box")
    assert current_belief(read_history(messages)) == expected  # the next turn is not changed by it
    moved = copy.deepcopy(LOOK)
    moved["locations"][1]["place_positions"][0]["occupied_by"] = None
    changed = conversation(moved)
    assert current_belief(read_history(changed)) == current_belief(afresh(changed)) != expected


def test_a_task_is_understood_as_its_reading_depends_on_what_is_believed_and_remembered() -> None:
    belief = Belief.from_look(LOOK)
    request = understand(TASK, belief, set(), [])
    assert request is not None and request.goals["mug"].location == "Front Door"
    assert understand(TASK, copy.deepcopy(belief), set(), None) == request
    gone = copy.deepcopy(belief)
    del gone.where["mug"]
    assert understand(TASK, gone, set(), []) != request  # no mug: another reading
    avoided = understand(TASK, belief, {"mug"}, [])
    assert avoided is not None and avoided.problem is not None and "cannot be grasped" in avoided.problem
    assert frozen([{"n": 1}]) != frozen([{"n": True}]) != frozen([{"n": 1.0}]) != frozen([{"n": "1"}])
    assert frozen([{"n": [1, "a"], "m": None}]) == frozen([{"n": [1, "a"], "m": None}])


def test_the_planner_decides_the_same_on_every_reading_of_a_conversation() -> None:
    messages = conversation()
    first = decide(messages)
    assert decide(messages) == decide(copy.deepcopy(messages)) == first == decide(list(messages))


def test_kept_holds_its_latest_entries() -> None:
    kept: Kept[str, int] = Kept(2)
    for i, key in enumerate("abcb"):
        kept[key] = i
    assert kept == {"b": 3, "c": 2}


def bfs(neighbours: dict[str, list[str]], start: str) -> dict[str, int]:
    dist, queue = {start: 0}, deque([start])
    while queue:
        node = queue.popleft()
        for nxt in neighbours.get(node, []):
            if nxt not in dist:
                dist[nxt] = dist[node] + 1
                queue.append(nxt)
    return dist


def test_the_hops_are_the_breadth_first_distances_of_the_map_as_it_is() -> None:
    belief = Belief.from_look(LOOK)
    for start in ["Hall", "Kitchen", "Front Door", "Nowhere"]:
        assert belief.hops_from(start) == bfs(belief.neighbours, start)
    belief.hops_from("Hall")["Kitchen"] = 99  # a caller's own copy
    belief.neighbours["Front Door"] = ["Hall", "Kitchen"]
    belief.neighbours["Kitchen"] = ["Hall", "Front Door"]
    assert belief.hop_table(["Hall", "Kitchen"]) == {s: bfs(belief.neighbours, s) for s in ["Hall", "Kitchen"]}


def test_a_search_s_remembered_estimates_are_those_of_a_fresh_problem() -> None:
    belief = Belief.from_look(LOOK)
    goals = {"mug": Goal("Front Door"), "cube": Goal("Kitchen"), "box": Goal("Hall", "bench")}
    found = rearrangement(belief, goals)
    assert found is not None
    problem, start = found
    seen, queue = {start}, deque([start])
    while queue and len(seen) < 400:
        state = queue.popleft()
        fresh = Rearrangement(*(getattr(problem, f) for f in problem.__dataclass_fields__))
        assert problem.estimate(state) == fresh.estimate(state)
        for _, nxt, _ in problem.successors(state):
            if nxt not in seen:
                seen.add(nxt)
                queue.append(nxt)
    assert any(state[2][state[1]] == HELD for state in seen if state[1] is not None)  # states holding one


def test_drives_along_sorted_edges_are_the_carrying_drives() -> None:
    edges = [("a", "b"), ("b", "c"), ("c", "a"), ("d", "e"), ("a", "a")]
    for here in "abcdez":
        moves = tuple(sorted(e for e in edges if e[0] != e[1]))
        assert drives_along(moves, here) == carrying_drives(edges, here) == carrying_drives(reversed(edges), here)
