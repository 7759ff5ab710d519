"""A submission: a study packed into one JSON file for a leaderboard elsewhere (`robocog submit`).

`prepare` writes what a leaderboard needs: every row (with its provenance), the sha256 of each row's
trace file and its text (`trace_texts`, what `robocog submit verify` replays; None where it was
missing), a digest of the rows, the suite and split the rows cover (or the tasks of a study of the
paper's tasks), the models with their protocol, model string and
sampling parameters, the trials per instance, and a summary per model (success, pass^k, cost).
`validate` checks that file: its format, that the rows and trace digests read and the rows' digest
matches them (a file edited after `prepare` does not), that every model covers every instance of
the split (for the paper's tasks, the first task: a later one runs only after it succeeded), and
that every instance has the declared number of trials per model and memory iteration. Whether the
rows ran on what robocog ships is not a validity question: it is part of the leaderboard's *verified*
mark, which `validate` reports too (the rest of the mark is the replay: `robocog submit verify`).
Every file is read within the bounds of `robocog.agent.analysis.untrusted`.
"""

from __future__ import annotations

import hashlib
import re
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from robocog.agent.analysis.leaderboard import Study, board, entry_json, results_study
from robocog.agent.analysis.provenance import trace_on_disk
from robocog.agent.analysis.replay_record import statuses
from robocog.agent.analysis.untrusted import (
    RESULTS_BYTES,
    TRACE_BYTES,
    Refused,
    read_bounded,
    read_json,
    split_directory,
    suite_directory,
)
from robocog.shared import __version__
from robocog.shared.evaluation import AttemptRow
from robocog.shared.provenance import sha256_of

FORMAT = "robocog-submission/1"
_DIGEST = re.compile(r"^[0-9a-f]{64}$")


def _suite_and_split(rows: Sequence[AttemptRow], local: Sequence[Path] = ()) -> tuple[str | None, str | None]:
    """The suite the rows' instances are of, and the one split that holds them all (a shipped suite, or
    a suite directory of `local`: `robocog.agent.analysis.untrusted.suite_directory`)."""
    from robocog.shared.suite import DEFAULT_SUITE, load_split

    instances = {r.instance for r in rows if r.instance}
    if not instances:
        return None, None
    named = {r.provenance.suite for r in rows if r.provenance and r.provenance.suite}
    suite = next(iter(named)) if len(named) == 1 else DEFAULT_SUITE
    fresh = {f"{p.split}@{p.split_seed}" for r in rows if (p := r.provenance) and p.split_seed is not None}
    if fresh:  # a fresh split, generated from a seed: the rows say which
        if len(fresh) > 1 or any(
            r.provenance is None or r.provenance.split_seed is None for r in rows if r.instance and r.earlier is None
        ):
            raise ValueError("the rows' instances are not all of one fresh split")
        split = next(iter(fresh))
        directory = split_directory(suite, split, local)
        if not instances <= {i.id for i in load_split(str(directory), split)}:
            raise ValueError(f"the rows' instances are not all of {suite} / {split}")
        return suite, split
    directory = suite_directory(suite, local)
    for path in sorted(directory.glob("*.jsonl")):
        if instances <= {i.id for i in load_split(str(directory), path.stem)}:
            return suite, path.stem
    raise ValueError(f"the rows' instances are not all of one split of the suite {suite}")


def _trace(path: Path) -> tuple[str, str | None]:
    """A trace file's sha256 and its text (None when it is not UTF-8: its digest alone is carried)."""
    data = read_bounded(path, TRACE_BYTES, "trace")
    try:
        text: str | None = data.decode("utf-8")
    except UnicodeDecodeError:
        text = None
    return hashlib.sha256(data).hexdigest(), text


def _trace_problem(texts: object, digests: list[Any]) -> str | None:
    """What is wrong with a submission's `trace_texts` (None: each is null or the text of its digest)."""
    if not isinstance(texts, list) or len(texts) != len(digests):
        return f"trace_texts must list one trace text (or null) per row: {len(digests)} rows"
    for number, (text, digest) in enumerate(zip(texts, digests, strict=True), 1):
        if text is None:
            continue
        if not isinstance(text, str) or len(text) > TRACE_BYTES:
            return f"the trace text of row {number} is not a text of at most {TRACE_BYTES:,} characters"
        if hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest() != digest:
            return f"the trace text of row {number} does not match its digest"
    return None


def _groups(rows: Sequence[AttemptRow], tasks: Sequence[str]) -> dict[tuple[str, str, int], int]:
    """Attempts per (model, instance or counted task, memory iteration); an instance's earlier task is
    no attempt at the instance (it has a row of its own)."""
    counts: dict[tuple[str, str, int], int] = defaultdict(int)
    for r in rows:
        if (r.instance and r.earlier is None) or (not r.instance and r.task in tasks):
            counts[(r.model, r.instance or r.task, r.memory_iteration)] += 1
    return counts


def prepare(results: Path, local: Sequence[Path] = ()) -> dict[str, Any]:
    """The submission of the study in `results` (its traces looked for beside it; its suite shipped, or
    one of the suite directories `local`)."""
    from robocog.agent.analysis.results_file import load_rows

    read_bounded(results, RESULTS_BYTES, "results file", content=False)
    rows = load_rows(results)
    if not rows:
        raise ValueError(f"{results}: the results file holds no attempts")
    base = results.resolve().parent
    present = trace_on_disk(base)
    read = [_trace(base / r.trace) if present(r) and r.trace else (None, None) for r in rows]  # not run: none
    traces = [digest for digest, _ in read]
    suite, split = _suite_and_split(rows, local)
    tasks = [] if suite else list(dict.fromkeys(r.task for r in rows))
    counted = _groups(rows, tasks[:1])
    models: dict[str, dict[str, Any]] = {}
    for r in rows:
        models.setdefault(
            r.model,
            {
                "model": r.model,
                "protocol": r.protocol,
                "model_id": r.model_id,
                "params": r.provenance.params if r.provenance else None,
            },
        )
    dumped = [r.model_dump(mode="json") for r in rows]
    study = Study(
        results.name,
        tuple(rows),
        tuple(t is not None or r.outcome == "not_run" for r, t in zip(rows, traces, strict=True)),
    )
    return {
        "format": FORMAT,
        "robocog_version": __version__,
        "study": rows[0].study or results.stem,
        "suite": suite,
        "split": split,
        "tasks": tasks,
        "models": list(models.values()),
        "trials_per_instance": max(counted.values(), default=0),
        "summary": [entry_json(e) for e in board([study]).entries],
        "rows_sha256": sha256_of(dumped),
        "traces": traces,
        "rows": dumped,
        "trace_texts": [text for _, text in read],
    }


@dataclass(frozen=True)
class Submission:
    """A submission that validated."""

    data: dict[str, Any]
    rows: tuple[AttemptRow, ...]

    def study(self, name: str) -> Study:
        traced = (t is not None or r.outcome == "not_run" for r, t in zip(self.rows, self.data["traces"], strict=True))
        return Study(name, self.rows, tuple(traced))  # an instance not run has no trace to have


def _coverage(data: dict[str, Any], rows: Sequence[AttemptRow], local: Sequence[Path]) -> list[str]:
    from robocog.shared.suite import load_split

    problems = []
    models = sorted({r.model for r in rows})
    if data.get("suite"):
        try:
            directory = split_directory(data["suite"], data["split"], local)
            wanted = [i.id for i in load_split(str(directory), data["split"])]
            fresh = "@" in data["split"] or any(r.provenance and r.provenance.split_seed is not None for r in rows)
            derived = _suite_and_split(rows, local) if fresh else (data["suite"], data["split"])
        except Refused as exc:
            return [str(exc)]
        except (OSError, ValueError) as exc:
            return [f"suite {data['suite']} / split {data['split']}: {' '.join(str(exc).split())}"]
        if derived != (data["suite"], data["split"]):  # a fresh split's seed is the rows' own
            return [f"it declares {data['suite']} / {data['split']}, but its rows ran on {derived[0]} / {derived[1]}"]
        where = f"{data['suite']}/{data['split']}"
    else:
        wanted = list(data.get("tasks") or [])[:1]
        where = "the study's first task"
    for m in models:
        have = {r.instance or r.task for r in rows if r.model == m}
        missing = [w for w in wanted if w not in have]
        if missing:
            shown = ", ".join(missing[:3]) + (", …" if len(missing) > 3 else "")
            problems.append(
                f"{m} covers {len(wanted) - len(missing)} of the {len(wanted)} of {where} ({shown} missing)"
            )
    trials = data.get("trials_per_instance")
    tasks = [] if data.get("suite") else wanted
    for (m, what, iteration), n in sorted(_groups(rows, tasks).items()):
        if n != trials:
            problems.append(f"{m} has {n} trials of {what} at memory iteration {iteration}, not {trials}")
            break
    return problems


#: A submission's fields and the JSON types each may hold (beside `format`, checked first).
_FIELDS: dict[str, tuple[type, ...]] = {
    "study": (str,),
    "suite": (str, type(None)),
    "split": (str, type(None)),
    "tasks": (list,),
    "models": (list,),
    "trials_per_instance": (int,),
    "summary": (list,),
    "rows_sha256": (str,),
    "traces": (list,),
    "rows": (list,),
    "trace_texts": (list,),
}
_NAMES = {list: "a list", dict: "an object", str: "a string", int: "an integer", type(None): "null"}


def _shape(data: dict[str, Any]) -> str | None:
    """The first field of a submission whose JSON type is wrong (None: every field's is right)."""
    for key, kinds in _FIELDS.items():
        value = data.get(key)
        if key in data and (not isinstance(value, kinds) or isinstance(value, bool)):
            return f"{key} must be {' or '.join(_NAMES[k] for k in kinds)}, not {_json_type(value)}"
    for number, task in enumerate(data.get("tasks") or [], 1):
        if not isinstance(task, str):
            return f"tasks: item {number} must be a string, not {_json_type(task)}"
    for number, model in enumerate(data.get("models") or [], 1):
        if not isinstance(model, dict) or not isinstance(model.get("model"), str):
            return f"models: item {number} must be an object whose model is a string"
    return None


def _json_type(value: object) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, float):
        return "a number"
    return next((n for t, n in _NAMES.items() if isinstance(value, t)), type(value).__name__)


def validate(data: Any, local: Sequence[Path] = ()) -> tuple[list[str], tuple[AttemptRow, ...]]:
    """The problems of a submission (none: valid) and its rows (when they read). Its suite is a shipped
    one or one of the suite directories `local` (given on the verifier's command line)."""
    if not isinstance(data, dict):
        return ["a submission is a JSON object"], ()
    if data.get("format") != FORMAT:
        return [f"format {str(data.get('format'))[:40]!r} is not {FORMAT!r}"], ()
    missing = [k for k in ("rows", "traces", "rows_sha256", "models", "trials_per_instance") if k not in data]
    if missing:
        return [f"missing {', '.join(missing)}"], ()
    wrong = _shape(data)
    if wrong:
        return [wrong], ()
    raw, traces = data["rows"], data["traces"]
    if not isinstance(raw, list) or not raw:
        return ["it holds no rows"], ()
    rows = []
    for number, item in enumerate(raw, 1):
        try:
            rows.append(AttemptRow.model_validate(item))
        except ValidationError as exc:
            return [f"row {number} is not a result row ({exc.error_count()} errors)"], ()
    if sha256_of(raw) != data["rows_sha256"]:
        return ["rows_sha256 does not match the rows (edited after robocog submit prepare?)"], tuple(rows)
    if not isinstance(traces, list) or len(traces) != len(rows):
        return [f"traces must list one digest (or null) per row: {len(rows)} rows"], tuple(rows)
    bad = [i for i, t in enumerate(traces, 1) if t is not None and not (isinstance(t, str) and _DIGEST.match(t))]
    if bad:
        return [f"the trace digest of row {bad[0]} is not a sha256"], tuple(rows)
    if "trace_texts" in data:  # what `robocog submit verify` replays (submissions before it carry none)
        wrong = _trace_problem(data["trace_texts"], traces)
        if wrong:
            return [wrong], tuple(rows)
    declared = {m["model"] for m in data["models"]}
    found = {r.model for r in rows}
    if declared != found:
        return [f"models lists {sorted(map(str, declared))} but the rows are of {sorted(found)}"], tuple(rows)
    return _coverage(data, rows, local), tuple(rows)


def read_submission(path: Path, local: Sequence[Path] = ()) -> Submission:
    """A submission file that validates (read within `robocog.agent.analysis.untrusted`'s bounds); a
    ValueError says its first problem in one line."""
    data = read_json(path)
    problems, rows = validate(data, local)
    if problems:
        raise ValueError(f"{path}: not a valid submission: {problems[0]}")
    return Submission(data, rows)


def load_study(path: Path, local: Sequence[Path] = ()) -> Study:
    """A results file (`.jsonl`) or a submission (`.json`, validated first; its suite shipped or one of
    the suite directories `local`), with its replay record (`robocog submit verify`) if one lies beside it."""
    study = read_submission(path, local).study(path.name) if path.suffix == ".json" else results_study(path)
    fresh = {(p.suite, p.split, p.split_seed) for r in study.rows if (p := r.provenance) and p.split_seed is not None}
    if len(fresh) > 1:  # each would be generated to check its rows: a study runs on one split
        raise ValueError(f"{path}: its rows ran on {len(fresh)} fresh splits; a study runs on one")
    return replace(study, replayed=statuses(path, len(study.rows)))
