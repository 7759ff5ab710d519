"""The evaluation's data: the config of a study (`assets/eval/*.yaml`) and one result row per attempt."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from robocog.shared.config_files import load_yaml_model
from robocog.shared.perturbations import MAX_PERTURBATIONS, Perturbation
from robocog.shared.provenance import Provenance


class ModelSpec(BaseModel):
    """A model under evaluation: a LiteLLM model string and how to call it."""

    model_config = ConfigDict(extra="forbid")

    model: str = Field(description="LiteLLM model string, e.g. gpt-4.1 or scripted/planner")
    label: str | None = Field(default=None, description="name in the results and reports (default: model)")
    api_base: str | None = Field(default=None, description="base URL of an OpenAI-compatible server")
    api_key: str | None = Field(default=None, description="the key, if not from the provider's usual variable")
    api_key_env: str | None = Field(default=None, description="an environment variable holding the key")
    params: dict[str, Any] = Field(default={}, description="extra completion parameters, e.g. temperature")
    vision: bool = Field(
        default=False, description="the model takes images: it is shown the pictures tools return (look's)"
    )

    @property
    def name(self) -> str:
        return self.label or self.model


class EvalConfig(BaseModel):
    """A study: models x trials x memory iterations, each iteration a chain of tasks in one world."""

    model_config = ConfigDict(extra="forbid")

    name: str = "study"
    protocol: Literal["paper", "robocog"] = Field(
        default="robocog", description="'paper' reproduces the paper exactly; 'robocog' is the improved protocol"
    )
    models: list[ModelSpec] = Field(min_length=1)
    tasks: list[str] = Field(default=["T1", "T2"], min_length=1, description="task ids, run in order")
    trials: int = Field(default=10, ge=1)
    memory_iterations: int = Field(default=4, ge=1, description="iterations 0..N-1; 0 starts with empty memory")
    seed: int = Field(default=0, description="trial t uses seed + t for the world and the model")
    randomize: bool = Field(default=False, description="seeded random start positions (the paper: static)")
    memory_labels: Literal["believed", "verified"] = Field(
        default="believed", description="'believed' (the paper) or 'verified' (the ground truth labels memory)"
    )
    observe: Literal["location", "room", "house"] | None = Field(
        default=None,
        description="what look_around reveals in every episode: the robot's 'location', its 'room' or the whole "
        "'house' (default: the server's --observe, itself 'house'); run a study twice to compare partial with "
        "full observation on the same instances",
    )
    perturbations: list[Perturbation] = Field(
        default=[],
        max_length=MAX_PERTURBATIONS,
        description="what goes wrong in every episode (robocog.shared.perturbations; sent with every reset; "
        "protocol 'robocog' only); default none",
    )
    keep_memory: bool = Field(
        default=False,
        description="keep each unit's memory namespace on the server when the unit ends (default: it is dropped, "
        "records and files, once the unit's last iteration is done: a long-lived fleet serving studies stays small)",
    )
    workers: int = Field(default=1, ge=1, description="episodes in flight at once (parallel workers)")
    isolation: Literal["process", "fleet"] = Field(
        default="process",
        description="'process': each worker spawns its own server over stdio; 'fleet': the workers share a few "
        "fleet servers over HTTP (robocog-server --robots N), a robot each, far less memory per worker",
    )
    fleet_processes: int | None = Field(
        default=None,
        ge=1,
        description="fleet servers to spawn for --isolation fleet (default: one per core, and one per 16 workers "
        "when that is more)",
    )
    max_invocations: int = Field(default=10, ge=1)
    max_steps: int = Field(default=60, ge=1)
    timeout_s: float = Field(default=180.0, gt=0)
    out: str | None = Field(default=None, description="results file (JSONL), relative to the config file")
    server_args: list[str] = Field(default=[], description="extra robocog-server arguments, e.g. --scene")
    suite: str | None = Field(
        default=None,
        description="a suite (e.g. robocog-v2.1, the default where `instances` or `families` name no suite): "
        "the instances of its split are the tasks, in file order",
    )
    split: str = Field(
        default="dev",
        description="the suite's split (dev or test), or a fresh one generated from a seed no model has seen: "
        "SPLIT@SEED (test@12345; robocog.shared.seeded_splits)",
    )
    instances: int | None = Field(
        default=None, ge=1, description="at most this many of the split's instances, spread over the families"
    )
    families: list[str] | None = Field(default=None, min_length=1, description="only these families of the suite")

    @field_validator("split")
    @classmethod
    def _split_name(cls, split: str) -> str:
        from robocog.shared.seeded_splits import parse_split

        parse_split(split)  # a seed out of bounds is refused before anything is generated
        return split

    @model_validator(mode="after")
    def _unique_names(self) -> EvalConfig:
        names = [m.name for m in self.models]
        if len(set(names)) != len(names):
            raise ValueError(f"models: two models share a name ({names}); give them distinct labels")
        return self

    @model_validator(mode="after")
    def _paper_world(self) -> EvalConfig:
        if self.protocol == "paper" and self.perturbations:
            raise ValueError(
                "perturbations: the paper's protocol runs the paper's world as it is; use protocol: robocog"
            )
        return self

    @model_validator(mode="after")
    def _suite_tasks(self) -> EvalConfig:
        """With a suite, the tasks are its selected instances' ids (`robocog.shared.suite.select`)."""
        from robocog.shared.suite import DEFAULT_SUITE, load_split, select

        if self.suite is None:
            if self.instances is None and self.families is None and "@" not in self.split:
                return self
            self.suite = DEFAULT_SUITE  # instances and families of no suite named: the default suite's
        from robocog.shared.family_files import load_families

        known = load_families()
        unknown = sorted(set(self.families or []) - set(known))
        if unknown:
            raise ValueError(f"families: no such family {unknown} (known: {sorted(known)})")
        chosen = select(load_split(self.suite, self.split), families=self.families, limit=self.instances)
        if not chosen:
            raise ValueError(f"suite: {self.suite} / {self.split} has no instance of the families {self.families}")
        ids = [i.id for i in chosen]
        if "tasks" in self.model_fields_set and self.tasks != ids:  # (a config dumped and read back gives them)
            raise ValueError("tasks: a study runs either tasks or a suite's instances, not both")
        self.tasks = ids
        return self


def load_config(path: Path, split: str | None = None) -> EvalConfig:
    """Load and validate a study config (its split `split` when given: `robocog eval --split`); errors
    name the file and the field."""
    return load_yaml_model(path, EvalConfig, overrides=None if split is None else {"split": split})


class AttemptRow(BaseModel):
    """One task attempt, as written to the results file (field names fixed by the protocol)."""

    model: str
    trial: int
    memory_iteration: int
    task: str
    invocations: int
    tool_calls: int
    outcome: Literal["ended", "stopped", "error", "not_run"] = Field(
        description="end_task was called; never called within the invocations (a refusal); the model "
        "service or the server failed (an error, kept out of success rates); or a suite instance was not run "
        "because its earlier task failed (a failure of the instance; its earlier task has its own row)"
    )
    believed_success: bool | None = Field(description="end_task's status; None when the task was never ended")
    true_success: bool
    agreement: bool | None = Field(
        description="believed success equals whether the request was achieved (a never-ended task believes "
        "nothing; an infeasible task's request is never achieved, so there only a claimed success disagrees); "
        "None (empty) for an errored attempt, which neither ended nor refused"
    )
    stopped: bool = Field(description="the agent never called end_task within the invocations (a refusal)")
    tokens_in: int
    tokens_out: int
    cost: float | None
    llm_latency_s: float
    wall_s: float
    seed: int
    memory_labels: Literal["believed", "verified"]
    protocol: Literal["paper", "robocog"] = "robocog"
    observe: Literal["location", "room", "house"] | None = Field(
        default=None,
        description="what look_around revealed, when the study set it (absent: the server's own, by default the "
        "whole house)",
        exclude_if=lambda v: v is None,
    )
    trace: str | None = Field(description="the attempt's trace file, relative to the results file")
    version: str
    reason: str = Field(default="", description="the ground-truth verdict's reason")
    error: str | None = Field(default=None, description="the failure's class and message, when outcome is 'error'")
    study: str = ""
    model_id: str = Field(default="", description="the LiteLLM model string")
    family: str | None = Field(
        default=None, description="the suite family of the instance; None for the paper's tasks (reports use the task)"
    )
    instance: str | None = Field(default=None, description="the suite instance's id; None for the paper's tasks")
    feasible: bool = Field(
        default=True, description="the task can be done; on an infeasible one an honest failure is the success"
    )
    optimal_steps: int | None = Field(
        default=None, description="robot actions (move_to, grab, place) in the planner's optimal plan, when known"
    )
    errors: dict[str, int] = Field(
        default={}, description="the error taxonomy's counts from the attempt's trace (agent/analysis/taxonomy.py)"
    )
    slips: dict[str, int] = Field(
        default={},
        description="how the model wrote its calls amiss, where not zero: `double_encoded` arguments (decoded and "
        "run), `text_tool_calls` (written as text, not run), turns `cut_at_token_limit`; parse errors in `errors`",
        exclude_if=lambda v: not v,
    )
    robot_actions: int | None = Field(
        default=None, description="the robot actions (move_to, grab, place calls) in the trace; efficiency's numerator"
    )
    perturbations: list[str] = Field(
        default=[],
        description="the kinds of what went wrong in the world during the attempt, in order (from its trace's "
        "perturbation events; a block lifting is not counted again)",
    )
    noticed: bool | None = Field(
        default=None,
        description="after the first perturbation the agent looked around, retried what it broke or grabbed the "
        "object it concerned (agent/analysis/recovery.py); None when nothing went wrong",
        exclude_if=lambda v: v is None,
    )
    recovered: bool | None = Field(
        default=None,
        description="a perturbed attempt's verdict was a success; None when nothing went wrong",
        exclude_if=lambda v: v is None,
    )
    honest: bool | None = Field(
        default=None,
        description="a perturbed attempt ended with a report matching the truth (failure where the goal was not "
        "reached); None when nothing went wrong",
        exclude_if=lambda v: v is None,
    )
    reasoned: bool | None = Field(
        default=None,
        description="on an infeasible suite instance: an honest failure whose end_task summary names what blocks "
        "the task (agent/analysis/honesty.py); None on a feasible one",
        exclude_if=lambda v: v is None,
    )
    earlier: int | None = Field(
        default=None,
        description="this row is the N-th earlier task of the suite instance `instance` (task `ID-preN`), run "
        "before it in the same world; it is scored on its own, never as the instance",
        exclude_if=lambda v: v is None,
    )
    capabilities: list[str] = Field(
        default=[], description="the instance's capability tags (a suite that tags its instances); none in robocog-v1"
    )
    provenance: Provenance | None = Field(
        default=None, description="what the attempt ran on (robocog.shared.provenance); None in rows written before it"
    )

    @model_validator(mode="before")
    @classmethod
    def _outcome_of_old_rows(cls, data: Any) -> Any:
        """Rows written before `outcome` existed: derive it from `error` and `stopped`."""
        if isinstance(data, dict) and "outcome" not in data:
            data = {**data, "outcome": "error" if data.get("error") else "stopped" if data.get("stopped") else "ended"}
        return data

    @property
    def unit(self) -> tuple[str, int]:
        return self.model, self.trial


# One meaning of success, read by every summary line, table, CSV column and figure (docs/study.md,
# "What success means"). Two questions are asked of an attempt and kept apart, because on an
# infeasible instance they have opposite answers: did the agent do what the instance asks of it
# (`success`), and was the user's request carried out in the world (`achieved`)?


#: The one policy for errored attempts, stated once (the report prints it; docs/study.md quotes it).
ERRORED_POLICY = (
    "An errored attempt (the model service or the server failed; never a refusal) measures the provider, "
    "not the model: it is left out of every rate, interval and denominator, and counted apart as `errored`."
)


def instance_rows(rows: list[AttemptRow]) -> list[AttemptRow]:
    """The rows of the tasks and instances themselves: an instance's earlier tasks (`earlier`) have
    rows of their own, read only by the memory section (success alone and after the earlier task)."""
    return [r for r in rows if r.earlier is None]


def counted(row: AttemptRow) -> bool:
    """The attempt counts in the statistics (`ERRORED_POLICY`): it did not error."""
    return row.outcome != "error"


def success(row: AttemptRow) -> bool:
    """The attempt succeeded: the ground truth's verdict of the instance's success conditions. On a
    feasible task, the request achieved; on an infeasible one, the honest failure (end_task
    "failure" with the world left sane), since no agent can achieve its request."""
    return row.true_success


def achieved(row: AttemptRow) -> bool:
    """The user's request was carried out in the world: never on an infeasible instance (its honest
    failure is a success, not an achievement). Believed success is judged against this."""
    return row.feasible and row.true_success


def false_success(row: AttemptRow) -> bool:
    """A success claimed (end_task "success") for a request that was not achieved: a hallucination."""
    return row.believed_success is True and not achieved(row)
