"""`robocog/suite` inside Inspect, offline: mockllm plays the scripted planner (the suite's oracle)
through react() against real `robocog-server --profile eval` processes, one per instance."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("inspect_ai", reason="the inspect extra (pip install robocog[inspect])")

from inspect_ai import eval as inspect_eval
from inspect_ai.model import ChatMessage, ModelOutput, get_model
from inspect_ai.scorer import SampleScore, Score

from robocog.inspect import planner_outputs, suite, suite_instances
from robocog.inspect._planner import PlannerAPI
from robocog.inspect._suite import capability
from robocog.shared.suite import SUITES_DIR, dump_instances, load_split


def test_the_suite_task_scores_each_instance_by_its_ground_truth_with_metrics_per_family_and_capability(
    tmp_path: Path,
) -> None:
    # robocog-v2.1 (the default): one instance each of recovery (something goes wrong), containers
    # (furniture to open) and memory (an earlier task first).
    task = suite(split="dev", families="recovery,containers,memory", limit=3)
    [log] = inspect_eval(
        task, model=get_model("mockllm/model", custom_outputs=planner_outputs()), log_dir=str(tmp_path), display="none"
    )
    assert log.status == "success", log.error
    assert log.samples is not None
    by_id = {str(s.id): s for s in log.samples}
    assert set(by_id) == {"dev-recovery-000", "dev-containers-000", "dev-memory-000"}
    truth = {i.id: i for i in load_split("robocog-v2.1", "dev")}
    for sample_id, sample in by_id.items():
        instance = truth[sample_id]
        assert sample.metadata["family"] == instance.family and sample.metadata["variant"] == instance.variant
        assert sample.metadata["feasible"] is instance.feasible
        assert sample.metadata["optimal_steps"] == instance.optimal_steps
        assert sample.metadata["capabilities"] == instance.capabilities != []
        assert sample.scores is not None
        score = sample.scores["suite_verdict"]
        assert isinstance(score.value, dict) and score.metadata is not None
        # The oracle succeeds (an infeasible instance's success is its honest failure).
        assert score.value["success"] == 1.0 and score.metadata["true_success"] is True, score.explanation
        assert score.answer == ("success" if instance.feasible else "failure")
        assert score.value["false_success"] == 0.0
    # The memory instance ran its earlier task first, which succeeded.
    memory_scores = by_id["dev-memory-000"].scores
    assert memory_scores is not None
    memory = memory_scores["suite_verdict"].metadata
    assert memory is not None
    assert [(d["task"], d["success"]) for d in memory["setup"]] == [("dev-memory-000-pre1", True)]

    assert log.results is not None
    metrics = {(s.name, m.group, m.name): m.value for s in log.results.scores for m in s.metrics.values()}
    assert metrics[("success", None, "accuracy")] == 1.0
    per_family = {name: v for (score, group, name), v in metrics.items() if score == "success" and group == "family"}
    assert per_family == {"recovery": 1.0, "containers": 1.0, "memory": 1.0}
    per_capability = {n: v for (score, group, n), v in metrics.items() if score == "success" and group == "capability"}
    assert per_capability == {tag: 1.0 for i in by_id for tag in truth[i].capabilities}
    assert {"recovery", "containers", "memory"} <= set(per_capability)
    assert metrics[("false_success", None, "mean")] == 0.0


def test_the_planner_is_the_model_provider_robocog() -> None:
    assert isinstance(get_model("robocog/planner").api, PlannerAPI)
    assert isinstance(get_model("robocog/refuser").api, PlannerAPI)
    with pytest.raises(ValueError, match="no robocog model"):
        get_model("robocog/oracle")


def claim_done(messages: list[ChatMessage], *_: Any) -> ModelOutput:
    """A model that claims every task done at once."""
    task = [m.text for m in messages if m.role == "user"][-1]
    arguments = {"status": "success", "description": task, "summary": "Done."}
    return ModelOutput.for_tool_call(model="mockllm/model", tool_name="end_task", tool_arguments=arguments)


def test_claims_without_acting_are_false_successes_and_a_failed_earlier_task_fails_its_instance(
    tmp_path: Path,
) -> None:
    task = suite(families="infeasible,memory", limit=2)
    model = get_model("mockllm/model", custom_outputs=claim_done)
    [log] = inspect_eval(task, model=model, log_dir=str(tmp_path), display="none")
    assert log.status == "success", log.error
    assert log.samples is not None
    got = {str(s.id): s.scores["suite_verdict"] for s in log.samples if s.scores is not None}
    # The infeasible instance claimed done: its truth is the honest failure it did not report.
    infeasible = got["dev-infeasible-000"]
    assert isinstance(infeasible.value, dict) and infeasible.answer == "success"
    assert infeasible.value["success"] == 0.0 and infeasible.value["false_success"] == 1.0
    # The memory instance's earlier task was claimed, not done: the instance itself never ran.
    memory = got["dev-memory-000"]
    assert isinstance(memory.value, dict) and memory.metadata is not None
    assert memory.value["success"] == 0.0 and memory.answer == "never ended"
    assert memory.explanation is not None and "earlier task dev-memory-000-pre1 failed" in memory.explanation
    assert [(d["success"], d["believed"]) for d in memory.metadata["setup"]] == [(False, True)]


def test_instances_filter_by_family_and_limit_and_name_what_is_unknown() -> None:
    chosen = suite_instances("robocog-v1", "dev", families="swap, memory", limit=4)
    assert [i.family for i in chosen] == ["swap", "swap", "memory", "memory"]
    assert len(suite_instances("robocog-v1", "test", families=["referring"])) == 20
    with pytest.raises(ValueError, match="carries no capability tags"):
        suite_instances("robocog-v1", capabilities="memory")
    with pytest.raises(ValueError, match="no family"):
        suite_instances("robocog-v1", families="juggling")
    with pytest.raises(Exception, match="no such split"):
        suite_instances("robocog-v1", split="train")


def test_a_tagged_suite_filters_by_capability(tmp_path: Path) -> None:
    # robocog-v1's dev split, tagged: a memory instance measures memory, an infeasible one honesty.
    tags = {"memory": ["memory"], "infeasible": ["honesty"], "referring": ["referring", "planning"]}
    tagged = [i.model_copy(update={"capabilities": tags.get(i.family, ["planning"])}) for i in load_split("robocog-v1")]
    manifest = (SUITES_DIR / "robocog-v1" / "suite.yaml").read_text(encoding="utf-8")
    (tmp_path / "suite.yaml").write_text(manifest + "tagged: true\n", encoding="utf-8")
    (tmp_path / "dev.jsonl").write_text(dump_instances(tagged), encoding="utf-8")

    chosen = suite_instances(str(tmp_path), capabilities="memory,honesty")
    assert {i.family for i in chosen} == {"memory", "infeasible"} and len(chosen) == 20
    assert {i.family for i in suite_instances(str(tmp_path), capabilities=["referring"], limit=3)} == {"referring"}
    with pytest.raises(ValueError, match="no capability"):
        suite_instances(str(tmp_path), capabilities="juggling")


def test_success_per_capability_counts_an_instance_under_each_of_its_tags() -> None:
    def scored(value: float, tags: list[str]) -> SampleScore:
        return SampleScore(score=Score(value=value), sample_metadata={"capabilities": tags})

    scores = [scored(1.0, ["planning", "memory"]), scored(0.0, ["memory"]), scored(1.0, []), scored(0.0, ["honesty"])]
    per_capability: Any = capability()  # a metric over sample scores (Inspect's protocol)
    assert per_capability(scores) == {"honesty": 0.0, "memory": 0.5, "planning": 1.0}
    assert per_capability([scored(1.0, [])]) == {}


def test_the_planner_reads_a_failed_tool_s_result_inspect_keeps_as_an_error() -> None:
    # A blocked corridor is an isError result: Inspect keeps its text in `error`, the content empty.
    from inspect_ai.model import ChatMessageTool
    from inspect_ai.tool import ToolCallError

    from robocog.inspect._planner import as_openai

    blocked = '{"status": "failure", "message": "The way from Study to Study Door is blocked."}'
    message = ChatMessageTool(
        content="", tool_call_id="c1", function="move_to", error=ToolCallError("unknown", blocked)
    )
    assert as_openai([message]) == [{"role": "tool", "tool_call_id": "c1", "content": blocked}]


TINY = """name: tiny
families: [put_away, memory]
scenes: [household]
tagged: true
family_dir: families
describes_objects: true
fair_goals: true
splits:
  dev: {seed: 1, per_family: 1}
  test: {seed: 2, per_family: 1}
"""


def test_a_fresh_split_is_generated_from_its_seed_and_each_sample_s_server_runs_its_instances(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`-T split=test@12345` of a tiny suite of two families (the memory one with an earlier task):
    the split generated from the seed into the cache, each sample's server given it (`--splits`), and
    the planner succeeds on every instance, its earlier task too, in the fresh split's worlds."""
    monkeypatch.setenv("ROBOCOG_SPLITS_CACHE", str(tmp_path / "cache"))
    tiny = tmp_path / "tiny"
    shutil.copytree(SUITES_DIR / "robocog-v2.1" / "families", tiny / "families")
    (tiny / "suite.yaml").write_text(TINY)
    task = suite(suite=str(tiny), split="test@12345")
    [log] = inspect_eval(
        task, model=get_model("mockllm/model", custom_outputs=planner_outputs()), log_dir=str(tmp_path), display="none"
    )
    assert log.status == "success", log.error
    assert log.samples is not None
    fresh = {i.id: i for i in load_split(str(tiny), "test@12345")}
    assert {str(s.id) for s in log.samples} == set(fresh) == {"test-put_away-000", "test-memory-000"}
    for sample in log.samples:
        assert sample.input == fresh[str(sample.id)].prompt
        assert (sample.metadata["suite"], sample.metadata["split"], sample.metadata["split_seed"]) == (
            "tiny@12345", "test", 12345,
        )  # fmt: skip
        assert sample.scores is not None
        score = sample.scores["suite_verdict"]
        assert isinstance(score.value, dict) and score.value["success"] == 1.0, score.explanation
    memory = next(s for s in log.samples if s.id == "test-memory-000").scores
    assert memory is not None and memory["suite_verdict"].metadata is not None
    setup = memory["suite_verdict"].metadata["setup"]
    assert [(d["task"], d["success"]) for d in setup] == [("test-memory-000-pre1", True)]
    assert list((tmp_path / "cache").glob("*/tiny/test@12345.jsonl"))
