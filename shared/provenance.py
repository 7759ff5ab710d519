"""Where a result row came from: the published contract's version, and sha256 digests (over canonical
JSON) of the tools as the model saw them, of the system prompt and of the task or suite instance.

A row's `provenance` (see `robocog.shared.evaluation.AttemptRow`) holds them with the model's sampling
parameters and the physics build the server ran (`physics_build`: upstream pybullet or its fork, and the
version, which the server announces in its instructions); the row itself carries robocog's version, the
protocol, the model string and the seed.
The same digests of what robocog ships (`shipped_tools_sha256`, `shipped_prompt_sha256`,
`shipped_task_sha256`) tell whether a row ran on unmodified prompts, tools and task files: the
leaderboard's *verified* mark. Canonical JSON: keys sorted, no spaces, UTF-8 (`canonical_json`).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import json
import re
from functools import cache
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from robocog.assets import ASSETS_DIR
from robocog.shared.protocol import APP_TOOLS, CONTROL_TOOLS, FURNITURE_TOOLS, ROBOT_ID_ARG, VISION_TOOLS


def canonical_json(value: Any) -> bytes:
    """`value` as canonical JSON: keys sorted, no whitespace, UTF-8."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode("utf-8")


def sha256_of(value: Any) -> str:
    """The hex sha256 of `value`'s canonical JSON."""
    return hashlib.sha256(canonical_json(value)).hexdigest()


def function_definition(name: str, description: str | None, input_schema: dict[str, Any] | None) -> dict[str, Any]:
    """An MCP tool as the OpenAI / LiteLLM function definition a model is offered: its input schema
    without the robot handle (`ROBOT_ID_ARG`), which a client passes itself, never the model."""
    parameters = input_schema or {"type": "object", "properties": {}}
    properties = parameters.get("properties")
    if isinstance(properties, dict) and ROBOT_ID_ARG in properties:
        parameters = {**parameters, "properties": {k: v for k, v in properties.items() if k != ROBOT_ID_ARG}}
        required = parameters.get("required")
        if isinstance(required, list) and ROBOT_ID_ARG in required:
            parameters["required"] = [r for r in required if r != ROBOT_ID_ARG]
    return {
        "type": "function",
        "function": {"name": name, "description": description or name, "parameters": parameters},
    }


def offered(name: str, *, vision: bool, furniture: bool = True) -> bool:
    """A tool a model is offered: never the harness's controls or the robot app's own, the camera only
    to a vision model, open and close only with `furniture` (under the robocog protocol, in a world
    with furniture that opens)."""
    return (
        name not in CONTROL_TOOLS
        and name not in APP_TOOLS
        and (vision or name not in VISION_TOOLS)
        and (furniture or name not in FURNITURE_TOOLS)
    )


def tools_sha256(definitions: list[dict[str, Any]]) -> str:
    """The digest of the function definitions a model was offered (in name order)."""
    return sha256_of(sorted(definitions, key=lambda d: str(d["function"]["name"])))


def text_sha256(text: str) -> str:
    """The digest of a prompt's text (surrounding whitespace aside)."""
    return sha256_of(text.strip())


#: The distributions known to provide the `pybullet` module: upstream, and the fork with wheels for macOS and
#: Windows (pyproject.toml selects one per environment).
PHYSICS_DISTRIBUTIONS = ("pybullet", "pybullet-arm64")
#: The physics build in a server's instructions: "Physics: pybullet 3.2.7." (`physics_build`).
PHYSICS_PATTERN = re.compile(r"\bPhysics: (\S+ \S+?)\.(?:\s|$)")


def physics_build() -> str | None:
    """The distribution whose `pybullet` module this process imports, and its version ("pybullet 3.2.7",
    "pybullet-arm64 3.2.8"); the module's file names it when more than one is installed. None without
    the module; "pybullet unknown" when no known distribution holds it (a build from source). Imports
    nothing of PyBullet."""
    spec = importlib.util.find_spec("pybullet")
    if spec is None or spec.origin is None:
        return None
    origin = Path(spec.origin).resolve()
    for name in PHYSICS_DISTRIBUTIONS:
        try:
            dist = importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            continue
        # its RECORD names the module's file, in the folder it is installed in (not every file's path resolved:
        # pybullet's RECORD lists some 9,000)
        installed_in = Path(str(dist.locate_file(""))).resolve()
        if origin.parent == installed_in and f"\n{origin.name}," in f"\n{dist.read_text('RECORD') or ''}":
            return f"{dist.metadata['Name']} {dist.version}"
    return "pybullet unknown"


class Provenance(BaseModel):
    """What a row ran on, beyond the fields every row has (version, protocol, model_id, seed)."""

    model_config = ConfigDict(extra="forbid")

    contract: str | None = Field(description="the MCP contract version the server announced (None: it did not)")
    tools: list[str] = Field(description="the tools the model was offered, by name")
    tools_sha256: str = Field(description="sha256 of the offered tools' function definitions (canonical JSON)")
    system_prompt: str = Field(description="the MCP prompt used as the system prompt, by name")
    system_prompt_sha256: str = Field(description="sha256 of the system prompt's text")
    task_sha256: str | None = Field(description="sha256 of the task's catalogue entry, or of the suite instance")
    suite: str | None = Field(default=None, description="the suite of the instance, when the task is one")
    split: str | None = Field(default=None, description="the split of the instance (absent from older rows)")
    split_seed: int | None = Field(
        default=None,
        description="the seed the instance's split was generated from on demand (SPLIT@SEED); None: the split "
        "the suite ships",
    )
    params: dict[str, Any] = Field(default={}, description="the model's sampling parameters (the study's params)")
    vision: bool = Field(default=False, description="the model was shown pictures")
    physics: str | None = Field(
        default=None,
        description="the physics build the server ran, as it announced it: its distribution and version "
        "('pybullet 3.2.7', 'pybullet-arm64 3.2.8'); None: it did not announce one",
    )


# --- what robocog ships ------------------------------------------------------------------------------


@cache
def _shipped_tools() -> dict[str, dict[str, Any]]:
    contract = json.loads((ASSETS_DIR / "contract" / "eval.json").read_text(encoding="utf-8"))
    return {
        t["name"]: function_definition(t["name"], t.get("description") or t.get("title"), t.get("inputSchema"))
        for t in contract["tools"]
    }


def shipped_tools_sha256(names: list[str]) -> str | None:
    """The digest of the shipped contract's definitions of the tools `names` (None: one is not shipped)."""
    shipped = _shipped_tools()
    if any(n not in shipped for n in names):
        return None
    return tools_sha256([shipped[n] for n in names])


def shipped_prompt_sha256(name: str) -> str | None:
    """The digest of the shipped prompt `name` (assets/prompts/NAME.md), None when there is none."""
    path = ASSETS_DIR / "prompts" / f"{name}.md"
    if "/" in name or not path.is_file():
        return None
    return text_sha256(path.read_text(encoding="utf-8"))


@cache
def _shipped_tasks() -> dict[str, str]:
    from robocog.shared.tasks import load_tasks

    return {tid: sha256_of(spec.model_dump(mode="json")) for tid, spec in load_tasks(ASSETS_DIR / "tasks").items()}


def shipped_task_sha256(task: str, suite: str | None = None, split: str | None = None) -> str | None:
    """The digest of the shipped task `task` (assets/tasks) or of a shipped suite's instance (of a
    fresh split, `split` "SPLIT@SEED": the instance robocog's generator draws from that seed); None
    when robocog ships no such task."""
    if suite is None:
        return _shipped_tasks().get(task)
    from robocog.shared.suite import SUITE_NAME, SUITES_DIR, find_instance, load_split

    try:
        if split is not None and "@" in split:
            if not SUITE_NAME.fullmatch(suite) or not (SUITES_DIR / suite / "suite.yaml").is_file():
                return None
            found = [i for i in load_split(str(SUITES_DIR / suite), split) if i.id == task]
            return sha256_of(found[0].model_dump(mode="json")) if found else None
        return sha256_of(find_instance(suite, task).model_dump(mode="json"))
    except (KeyError, ValueError, FileNotFoundError):
        return None
