"""robocog inside Inspect (robocog.inspect), offline: Inspect's mockllm plays scripted tool calls
through react() against a real `robocog-server --profile eval` over stdio."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("inspect_ai", reason="the inspect extra (pip install robocog[inspect])")

from inspect_ai import eval as inspect_eval
from inspect_ai.log import EvalLog, read_eval_log
from inspect_ai.model import ChatMessageTool, ModelOutput, get_model

from robocog.inspect import ROBOT_TOOL_NAMES, t1
from tests.helpers import T1, T1_SEQUENCE, action_args

MOCK = "mockllm/model"


def tool_call(name: str, **arguments: Any) -> ModelOutput:
    return ModelOutput.for_tool_call(model=MOCK, tool_name=name, tool_arguments=arguments)


def end_task(status: str, summary: str) -> ModelOutput:
    return tool_call("end_task", status=status, description=T1, summary=summary)


def run_t1(outputs: list[ModelOutput], log_dir: Path) -> EvalLog:
    [log] = inspect_eval(
        t1(),
        model=get_model(MOCK, custom_outputs=outputs),
        log_dir=str(log_dir),
        display="none",
    )
    assert log.status == "success", log.error
    return log


def scores(log: EvalLog) -> dict[str, Any]:
    assert log.samples is not None
    [sample] = log.samples
    assert sample.scores is not None
    [score] = sample.scores.values()
    assert isinstance(score.value, dict)
    assert score.metadata is not None
    return {**score.value, **score.metadata, "answer": score.answer, "sample": sample}


def test_planner_t1_through_inspect_is_a_success_and_the_log_reads_back(tmp_path: Path) -> None:
    script = [tool_call(*a[:1], **action_args(a)) for a in T1_SEQUENCE]
    log = run_t1([*script, end_task("success", "All three items are on the shelf.")], tmp_path)

    got = scores(log)
    assert got["success"] == 1.0 and got["true_success"] is True
    assert got["believed_success"] is True and got["agreement"] is True and got["false_success"] == 0.0
    sample = got["sample"]
    assert sample.metadata == {"task": "T1", "seed": 0, "scene": "household", "randomize": False}
    # The model was offered the eight robot tools and never a control.
    offered = {tool.name for event in sample.events if event.event == "model" for tool in event.tools}
    assert offered == set(ROBOT_TOOL_NAMES)
    # Every scripted call ran without error, ending with end_task.
    results = [m for m in sample.messages if isinstance(m, ChatMessageTool)]
    assert [m.function for m in results] == [a[0] for a in T1_SEQUENCE] + ["end_task"]
    assert all(m.error is None for m in results)

    assert log.location and Path(log.location).exists()
    back = read_eval_log(log.location)
    assert back.eval.task.endswith("t1")
    assert back.results is not None
    metrics = {(s.name, k): m.value for s in back.results.scores for k, m in s.metrics.items()}
    assert metrics[("success", "accuracy")] == 1.0
    assert metrics[("false_success", "mean")] == 0.0
    assert metrics[("believed_success", "mean")] == 1.0


def test_a_false_success_claim_scores_as_wrong(tmp_path: Path) -> None:
    # Only the cube goes to the shelf, then the model claims the whole task done.
    script = [tool_call(*a[:1], **action_args(a)) for a in T1_SEQUENCE[:4]]
    log = run_t1([*script, end_task("success", "Everything is put away.")], tmp_path)

    got = scores(log)
    assert got["success"] == 0.0 and got["true_success"] is False
    assert got["believed_success"] is True and got["answer"] == "success"
    assert got["false_success"] == 1.0 and got["agreement"] is False
    assert "mug" in got["sample"].scores["robocog_verdict"].explanation
