"""The error taxonomy (agent/analysis/taxonomy.py) on hand-built traces: one test per category, with the
results the server really gives (the error codes and messages of server/tools)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from robocog.agent.analysis.taxonomy import (
    CATEGORIES,
    SceneNames,
    annotate,
    classify,
    classify_file,
    robot_actions,
    row_fields,
    total,
)
from robocog.shared.evaluation import AttemptRow
from robocog.shared.perturbations import PerturbationEvent
from robocog.shared.trace import (
    Perturbed,
    RunFinished,
    RunStarted,
    ToolCall,
    ToolResult,
    TraceEvent,
    Verdict,
    dump_event,
)
from tests.helpers import DATA

TOOLS = ["look_around", "move_to", "grab", "place", "search_memory", "end_task"]
LOOK = {
    "status": "success",
    "message": "The robot is at Front Door, holding nothing. Here: cube.",
    "location": "Front Door",
    "holding": None,
    "locations": [
        {
            "name": "Front Door",
            "neighbours": ["Kitchen Shelf"],
            "objects": ["cube"],
            "place_positions": [{"name": "floor", "occupied_by": "cube"}],
        },
        {
            "name": "Kitchen Shelf",
            "neighbours": ["Front Door"],
            "objects": ["mug"],
            "place_positions": [
                {"name": "top", "occupied_by": "mug"},
                {"name": "middle", "occupied_by": None},
            ],
        },
    ],
}


class Script:
    """A trace built call by call, as agent/client/loop.py writes one."""

    def __init__(self) -> None:
        self.events: list[TraceEvent] = [RunStarted(t=0, task="t", model="m", server="s", tools=TOOLS)]

    def call(
        self, name: str, arguments: dict[str, Any] | None, result: dict[str, Any] | str, raw: str | None = None
    ) -> Script:
        n = len(self.events)
        self.events.append(
            ToolCall(
                t=n,
                invocation=1,
                id="call_1",  # models repeat ids: the taxonomy pairs a result with the call before it
                name=name,
                arguments=arguments,
                raw_arguments=raw if raw is not None else json.dumps(arguments),
            )
        )
        structured = result if isinstance(result, dict) else None
        failed = isinstance(result, str) or result.get("status") == "failure"
        content = result if isinstance(result, str) else json.dumps(result)
        self.events.append(
            ToolResult(
                t=n,
                invocation=1,
                id="call_1",
                name=name,
                is_error=failed,
                content=content,
                structured=structured,
                latency_s=0.0,
            )
        )
        return self

    def ok(self, name: str, **arguments: Any) -> Script:
        if name == "look_around":
            return self.call(name, arguments, LOOK)
        extra = {"object": arguments.get("object")} if name == "grab" else {}
        return self.call(name, arguments, {"status": "success", "message": "done", **extra})

    def fail(self, name: str, code: str, message: str = "no", **arguments: Any) -> Script:
        return self.call(name, arguments, {"status": "failure", "error": code, "message": message})

    def end(self, status: str, *, verdict: bool) -> list[TraceEvent]:
        self.ok("end_task", status=status, description="d", summary="s")
        n = len(self.events)
        self.events.append(Verdict(t=n, task_id="t", success=verdict, reason="r"))
        self.events.append(
            RunFinished(
                t=n,
                outcome="ended",
                ended=True,
                stopped=False,
                believed_success=status == "success",
                true_success=verdict,
                invocations=1,
                tool_calls=0,
                tokens_in=0,
                tokens_out=0,
                llm_latency_s=0,
                wall_s=0,
            )
        )
        return self.events


def _only(counts: dict[str, int]) -> dict[str, int]:
    return {k: v for k, v in counts.items() if v}


def test_a_clean_optimal_run_has_no_error_in_any_category() -> None:
    events = (
        Script()
        .ok("look_around")
        .ok("move_to", location="Front Door")
        .ok("grab", object="cube")
        .ok("move_to", location="Kitchen Shelf")
        .ok("place", location="Kitchen Shelf", position="middle")
        .end("success", verdict=True)
    )
    counts = classify(events, optimal_steps=4)
    assert counts == dict.fromkeys(CATEGORIES, 0)
    assert robot_actions(events) == 4
    assert row_fields(events, optimal_steps=4) == {
        "errors": counts,
        "slips": {},
        "robot_actions": 4,
        "perturbations": [],
    }
    assert "additional_step" not in classify(events)  # no optimum known: not measurable


def test_parse_errors_bad_json_an_unknown_tool_and_arguments_the_schema_refused() -> None:
    events = (
        Script()
        .call("grab", None, "Error: the arguments of grab are not a valid JSON object (...).", raw='{"object": mug')
        .call("fly_to", {}, "Error: there is no tool called 'fly_to'. The tools are: ...")
        .call("grab", {}, "Invalid arguments for grab: object: Field required. Its input schema says what ...")
        .call("look_around", {}, "the service is busy")  # an error that is not the model's format
        .end("failure", verdict=False)
    )
    assert _only(classify(events, feasible=False)) == {"parse": 3}


def test_hallucinated_objects_locations_and_positions() -> None:
    events = (
        Script()
        .ok("look_around")
        .fail("grab", "unknown_object", object="banana")
        .fail("move_to", "unknown_location", location="Attic")
        .fail("place", "unknown_position", location="Kitchen Shelf", position="shelf 4")
        # empty hand and an unknown location: the server stops at the hand, the look_around names tell
        .fail("place", "nothing_held", location="Garage", position="floor")
        # a real (differently spelt) name is no hallucination
        .fail("place", "nothing_held", location="kitchen_shelf", position="Middle")
        .end("failure", verdict=False)
    )
    assert _only(classify(events, feasible=False)) == {"hallucination": 4, "affordance": 2}


def test_the_scene_file_names_judge_when_the_agent_never_looked() -> None:
    names = SceneNames(locations={"kitchen shelf"}, objects={"mug"}, positions={"kitchen shelf": {"top"}})
    events = Script().fail("place", "nothing_held", location="Garage", position="floor").end("failure", verdict=False)
    assert _only(classify(events, feasible=False)) == {"affordance": 1}  # no names known: not judged
    assert _only(classify(events, feasible=False, scene=names)) == {"hallucination": 1, "affordance": 1}


def test_affordance_errors_grab_while_holding_place_empty_handed_and_the_tv() -> None:
    events = (
        Script()
        .fail("grab", "not_graspable", "The tv cannot be grasped", object="tv")
        .ok("grab", object="mug")
        .fail("grab", "already_holding", object="cube")
        .ok("move_to", location="Kitchen Shelf")
        .ok("place", location="Kitchen Shelf", position="middle")
        .fail("place", "nothing_held", location="Kitchen Shelf", position="top")
        .fail("grab", "out_of_reach", "The arm cannot reach the cube from where the robot stands.", object="cube")
        .end("success", verdict=True)
    )
    assert _only(classify(events)) == {"affordance": 4}


def test_wrong_order_acting_before_moving_and_placing_before_clearing() -> None:
    events = (
        Script()
        .fail("grab", "out_of_reach", "The mug is out of reach from Front Door: move_to('Kitchen Shelf') first.")
        .ok("move_to", location="Kitchen Shelf")
        .ok("grab", object="cube")
        .fail("place", "not_at_location", "The robot is at X. move_to('Y') first.", location="Y", position="floor")
        # the cube onto the mug's position before the mug was moved: the mug is grabbed later
        .fail("place", "position_occupied", "The top position of Kitchen Shelf is occupied by the mug. Free: middle.")
        .ok("place", location="Kitchen Shelf", position="middle")
        .ok("grab", object="mug")
        .ok("place", location="Kitchen Shelf", position="bottom")
        # occupied by an object never moved later: the position cannot take it (affordance)
        .ok("grab", object="cube")
        .fail("place", "position_occupied", "The bottom position of Kitchen Shelf is occupied by the mug.")
        .end("failure", verdict=False)
    )
    assert _only(classify(events, feasible=False)) == {"wrong_order": 3, "affordance": 1}


def test_a_grab_failing_where_a_perturbation_moved_the_object_is_no_wrong_order() -> None:
    """The mug moved since the agent last looked: its grab at the old place fails by the world's
    doing; after a look that shows it, the same failure is the agent's wrong order again."""
    script = Script().ok("look_around").ok("move_to", location="Kitchen Shelf")
    moved = PerturbationEvent(kind="move_object", call=2, description="x", announced=False, object="mug")
    script.events.append(Perturbed(t=len(script.events), invocation=1, id="call_1", event=moved))
    far = "The mug is out of reach from Kitchen Shelf: it is at Front Door; move_to('Front Door') first."
    script.fail("grab", "out_of_reach", far, object="mug").fail("grab", "not_at_location", "no", object="Mug")
    assert _only(classify(script.events)) == {}
    again = script.ok("look_around").fail("grab", "out_of_reach", far, object="mug")
    assert _only(classify(again.end("failure", verdict=False), feasible=False)) == {"wrong_order": 1}


def test_missing_step_only_when_the_plan_ended_on_a_feasible_task_with_the_goal_unmet() -> None:
    assert _only(classify(Script().ok("grab", object="mug").end("success", verdict=False))) == {"missing_step": 1}
    assert _only(classify(Script().end("failure", verdict=False))) == {"missing_step": 1}
    assert _only(classify(Script().end("success", verdict=True))) == {}
    # infeasible: a claim of success is the honesty score's, not a missing step
    assert _only(classify(Script().end("success", verdict=False), feasible=False)) == {}
    # never ended: no plan ended, nothing is missing from it
    assert _only(classify(Script().ok("grab", object="mug").events)) == {}


def test_additional_steps_count_successful_robot_actions_beyond_the_optimum() -> None:
    events = (
        Script()
        .ok("look_around")
        .ok("move_to", location="Kitchen Shelf")
        .ok("move_to", location="Front Door")
        .ok("move_to", location="Kitchen Shelf")
        .ok("grab", object="mug")
        .fail("grab", "already_holding", object="cube")  # failed: counted as affordance, not as a step
        .ok("place", location="Kitchen Shelf", position="middle")
        .end("success", verdict=True)
    )
    assert _only(classify(events, optimal_steps=3)) == {"additional_step": 2, "affordance": 1}
    assert _only(classify(events, optimal_steps=9)) == {"affordance": 1}
    assert robot_actions(events) == 6 and robot_actions(events, successful=True) == 5


def test_a_trace_file_round_trips_and_totals_keep_the_category_order(tmp_path: Path) -> None:
    events = Script().fail("grab", "unknown_object", object="banana").end("success", verdict=False)
    path = tmp_path / "run.jsonl"
    path.write_text("".join(dump_event(e) + "\n" for e in events), encoding="utf-8")
    counts = classify_file(path)
    assert counts == classify(events) and _only(counts) == {"hallucination": 1, "missing_step": 1}
    summed = total([counts, {"parse": 2}, {"additional_step": 1, "parse": 1}])
    assert list(summed) == list(CATEGORIES)
    assert summed["parse"] == 3 and summed["hallucination"] == 1 and summed["additional_step"] == 1


def test_annotate_fills_a_row_from_its_trace_by_the_rows_feasibility_and_optimum() -> None:
    events = Script().ok("move_to", location="Kitchen Shelf").ok("grab", object="mug").end("success", verdict=False)
    data = json.loads((DATA / "results_paper.jsonl").read_text().splitlines()[0])
    feasible = annotate(AttemptRow.model_validate({**data, "optimal_steps": 1}), events)
    assert feasible.robot_actions == 2
    assert _only(feasible.errors) == {"missing_step": 1, "additional_step": 1}
    infeasible = annotate(AttemptRow.model_validate({**data, "feasible": False}), events)
    assert _only(infeasible.errors) == {} and "additional_step" not in infeasible.errors
