"""Provenance (shared/provenance.py, agent/analysis/provenance.py): the digests of what robocog ships,
where the rows of one file disagree, and what keeps rows from the leaderboard's *verified* mark."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from robocog.agent.analysis.provenance import disagreements, row_problems, trace_on_disk, verify
from robocog.agent.analysis.results_file import read_rows
from robocog.assets import ASSETS_DIR
from robocog.shared.evaluation import AttemptRow
from robocog.shared.protocol import CONTRACT_VERSION, PAPER_TOOLS
from robocog.shared.provenance import (
    PHYSICS_PATTERN,
    Provenance,
    canonical_json,
    physics_build,
    sha256_of,
    shipped_prompt_sha256,
    shipped_task_sha256,
    shipped_tools_sha256,
    text_sha256,
)
from tests.helpers import DATA


def shipped(task: str = "T1", **change: object) -> Provenance:
    """The provenance of a row that ran on what robocog ships (the robocog protocol's prompt)."""
    tools = sorted(PAPER_TOOLS)
    fields: dict[str, object] = {
        "contract": CONTRACT_VERSION,
        "tools": tools,
        "tools_sha256": shipped_tools_sha256(tools),
        "system_prompt": "robot_system",
        "system_prompt_sha256": shipped_prompt_sha256("robot_system"),
        "task_sha256": shipped_task_sha256(task),
        "params": {},
    }
    return Provenance.model_validate({**fields, **change})


def rows(**change: object) -> list[AttemptRow]:
    """The committed small file (written before provenance), each row given `shipped()` provenance."""
    return [
        r.model_copy(update={"provenance": shipped(r.task), **change}) for r in read_rows(DATA / "results_small.jsonl")
    ]


def test_canonical_json_sorts_keys_and_drops_whitespace() -> None:
    assert canonical_json({"b": [1, 2], "a": "é"}) == '{"a":"é","b":[1,2]}'.encode()
    assert sha256_of({"a": 1, "b": 2}) == sha256_of({"b": 2, "a": 1}) != sha256_of({"a": 1, "b": 3})
    assert text_sha256(" prompt\n") == text_sha256("prompt")


def test_the_shipped_digests_are_of_the_shipped_files() -> None:
    prompt = (ASSETS_DIR / "prompts" / "robot_system_paper.md").read_text(encoding="utf-8")
    assert shipped_prompt_sha256("robot_system_paper") == text_sha256(prompt)
    assert shipped_prompt_sha256("robot_system") != shipped_prompt_sha256("robot_system_paper")
    assert shipped_prompt_sha256("../contract/eval") is None and shipped_prompt_sha256("nothing") is None
    assert shipped_task_sha256("T1") != shipped_task_sha256("T2") and shipped_task_sha256("T9") is None
    first = json.loads((ASSETS_DIR / "suites" / "robocog-v1" / "dev.jsonl").read_text().splitlines()[0])
    assert shipped_task_sha256(first["id"], "robocog-v1") is not None
    assert shipped_task_sha256(first["id"], "no-such-suite") is None
    assert shipped_tools_sha256(["look_around", "no_such_tool"]) is None
    assert shipped_tools_sha256(["look_around", "grab"]) == shipped_tools_sha256(["grab", "look_around"])


def test_old_rows_without_provenance_still_load_and_agree() -> None:
    old = read_rows(DATA / "results_small.jsonl")
    assert old and all(r.provenance is None and r.capabilities == [] for r in old)
    assert disagreements(old) == []
    assert disagreements(rows()) == []


def test_disagreements_name_what_differs_and_how_many_rows_hold_each_value() -> None:
    mixed = rows()
    mixed[0] = mixed[0].model_copy(update={"provenance": shipped("T1", params={"temperature": 0.6})})
    mixed[1] = mixed[1].model_copy(update={"version": "9.9.9"})
    mixed[2] = mixed[2].model_copy(update={"provenance": None})
    other_prompt = shipped(mixed[3].task, system_prompt_sha256=text_sha256("be brief"))
    mixed[3] = mixed[3].model_copy(update={"provenance": other_prompt})
    lines = disagreements(mixed)
    assert f"1 of {len(mixed)} rows carry no provenance (written by a robocog before it)" in lines
    assert any(
        line.startswith("rows disagree on the robocog version: 0.1.0 (") and "9.9.9 (1 rows)" in line for line in lines
    )
    assert any(line.startswith(f"rows of {mixed[0].model} disagree on the sampling parameters") for line in lines)
    assert any(line.startswith(f"rows of {mixed[3].model} disagree on the system prompt") for line in lines)
    changed_task = rows()
    changed_task[0] = changed_task[0].model_copy(update={"provenance": shipped("T1", task_sha256="0" * 64)})
    assert [line for line in disagreements(changed_task) if "task's digest" in line] == [
        f"rows of T1 disagree on the task's digest: {shipped_task_sha256('T1')[:12]} "  # type: ignore[index]
        f"({sum(r.task == 'T1' for r in changed_task) - 1} rows), 000000000000 (1 rows)"
    ]


def test_rows_of_different_physics_builds_are_marked() -> None:
    """Rows that ran on upstream pybullet and on its fork are told apart; rows before the field say nothing."""
    mixed = rows(provenance=None)
    mixed = [r.model_copy(update={"provenance": shipped(r.task, physics="pybullet 3.2.7")}) for r in mixed]
    assert disagreements(mixed) == []
    fork = shipped(mixed[0].task, physics="pybullet-arm64 3.2.8")
    mixed[0] = mixed[0].model_copy(update={"provenance": fork})
    assert disagreements(mixed) == [
        f"rows disagree on the physics build: pybullet 3.2.7 ({len(mixed) - 1} rows), pybullet-arm64 3.2.8 (1 rows)"
    ]
    assert "physics" not in shipped().model_dump(exclude_defaults=True)  # older rows load, with None


def _fake_physics(site: Path, dist_info: str | None) -> None:
    """A `pybullet` module in `site`, installed by the distribution `dist_info` ("name-version"), or by none."""
    site.mkdir()
    (site / "pybullet.py").write_text("")
    if dist_info is not None:
        meta = site / f"{dist_info}.dist-info"
        meta.mkdir()
        name, version = dist_info.split("-", 1)
        (meta / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name.replace('_', '-')}\nVersion: {version}\n")
        (meta / "RECORD").write_text(f"pybullet.py,,\n{meta.name}/METADATA,,\n{meta.name}/RECORD,,\n")


@pytest.mark.parametrize(
    ("dist_info", "build"),
    [
        ("pybullet_arm64-3.2.8", "pybullet-arm64 3.2.8"),
        ("pybullet-9.9.9", "pybullet 9.9.9"),
        (None, "pybullet unknown"),
    ],
)
def test_physics_build_names_the_distribution_of_the_module_imported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, dist_info: str | None, build: str
) -> None:
    """The module first on the path decides, even with the other build installed (this virtualenv's)."""
    assert physics_build() is not None  # this virtualenv's own
    _fake_physics(tmp_path / "site", dist_info)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.delitem(sys.modules, "pybullet", raising=False)
    assert physics_build() == build
    found = PHYSICS_PATTERN.search(f"robocog MCP contract 4.0. Physics: {build}.")
    assert found is not None and found.group(1) == build


def test_verified_only_with_shipped_prompt_tools_and_task_and_every_trace(tmp_path: Path) -> None:
    good = rows()
    assert row_problems(good[0]) == []
    assert verify(good, lambda r: True).verified
    assert verify(good, lambda r: False).problems == (f"trace missing ({len(good)} rows)",)
    edited = good[0].model_copy(update={"provenance": shipped("T1", system_prompt_sha256=text_sha256("x"))})
    assert row_problems(edited) == ["system prompt robot_system differs from the shipped one"]
    tools = good[0].model_copy(update={"provenance": shipped("T1", tools_sha256="1" * 64, contract="2.0")})
    assert row_problems(tools) == [
        f"contract 2.0 (shipped: {CONTRACT_VERSION})",
        "tools differ from the shipped contract's",
    ]
    task = good[0].model_copy(update={"task": "T2"})
    assert row_problems(task) == ["task T2 differs from the shipped one"]
    assert row_problems(good[0].model_copy(update={"provenance": None})) == ["no provenance"]
    (tmp_path / "t.jsonl").write_text("{}\n")
    present = trace_on_disk(tmp_path)
    assert present(good[0].model_copy(update={"trace": "t.jsonl"}))
    assert not present(good[0].model_copy(update={"trace": "gone.jsonl"})) and not present(good[0])


#: The digest of the paper's eight tools as a model was offered them under contract 3.3, before every
#: tool took `robot_id` (contract 4.0): a model's view of them must never change.
PAPER_TOOLS_AS_OFFERED = "220bbe28ae5830bc85f6b81a736f63d93d989cd029b912b17aba50e8a3161de2"


def test_a_model_is_offered_the_paper_tools_without_the_robot_handle() -> None:
    import json

    from robocog.shared.protocol import PAPER_TOOLS, ROBOT_ID_ARG
    from robocog.shared.provenance import function_definition, tools_sha256
    from tests.helpers import CONTRACT_DIR

    tools = json.loads((CONTRACT_DIR / "default.json").read_text(encoding="utf-8"))["tools"]
    assert all(ROBOT_ID_ARG in t["inputSchema"]["properties"] for t in tools), "the server declares it on every tool"
    offered = [
        function_definition(t["name"], t.get("description") or t.get("title"), t["inputSchema"])
        for t in tools
        if t["name"] in PAPER_TOOLS
    ]
    assert all(ROBOT_ID_ARG not in d["function"]["parameters"]["properties"] for d in offered)
    assert tools_sha256(offered) == PAPER_TOOLS_AS_OFFERED
