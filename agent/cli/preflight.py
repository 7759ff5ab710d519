"""What `run`, `chat` and `eval` check and say before anything starts: task ids that are not known
(with the closest known one), a model LiteLLM cannot route, a viewer port that is taken, and which
memory a spawned server will use and how many records it holds.

Each check raises `ConfigError` with one line; the command prints it and exits 2."""

from __future__ import annotations

import difflib
import os
import re
import sqlite3
from collections.abc import Iterable, Sequence
from functools import cache
from pathlib import Path

from robocog.agent.policies import is_offline
from robocog.shared.errors import ConfigError
from robocog.shared.process import probe_bind

#: A word a user means as a task id, not as an instruction: one token with a digit and no spaces
#: (T1, t1, T3, task2, dev-put_away-000). A free-text instruction has spaces or no digit.
_ID_SHAPE = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*\d[A-Za-z0-9_\-]*$")


@cache
def known_task_ids() -> tuple[str, ...]:
    """The ids of the shipped task catalogue (assets/tasks), as the server's robocog://tasks lists them."""
    from robocog.assets import ASSETS_DIR
    from robocog.shared.tasks import load_tasks

    return tuple(load_tasks(ASSETS_DIR / "tasks"))


def looks_like_task_id(word: str) -> bool:
    """Whether `word` is shaped like a task id (rather than an instruction in words)."""
    return bool(_ID_SHAPE.match(word.strip()))


def unknown_task_id(word: str, known: Iterable[str] | None = None, *, instructions: bool = True) -> str | None:
    """The one-line complaint about `word` when it is not a known task id (with `instructions`, only
    when it is also shaped like one: other words are an instruction to send as it is); else None."""
    ids = list(known if known is not None else known_task_ids())
    word = word.strip()
    if word in ids or (instructions and not looks_like_task_id(word)):
        return None
    closest = closest_name(word, ids)
    hint = f"; did you mean {closest}?" if closest else ""
    example = ' (an instruction in words is sent as it is, e.g. "Put the mug on the Kitchen Table.")'
    return f"unknown task id {word!r}: the known task ids are {', '.join(ids)}{hint}" + (
        example if instructions else ""
    )


def closest_name(word: str, names: Sequence[str]) -> str | None:
    """The name of `names` most like `word`, ignoring case: by similarity, then by the longest common
    start, then the first listed (T12 -> T1; t2 -> T2)."""

    def likeness(name: str) -> tuple[float, int]:
        a, b = word.casefold(), name.casefold()
        start = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), min(len(a), len(b)))
        return difflib.SequenceMatcher(None, a, b).ratio(), start

    return max(names, key=likeness) if names else None


def check_task_words(words: Iterable[str], where: str = "") -> None:
    """`ConfigError` for the first of `words` that looks like a task id and is not one."""
    for word in words:
        problem = unknown_task_id(word)
        if problem is not None:
            raise ConfigError(f"{where}{problem}")


def check_model(model: str, api_base: str | None, api_key: str | None = None) -> None:
    """`ConfigError` when LiteLLM cannot tell which provider serves `model` (a typo such as gpt4o),
    unless `api_base` names an OpenAI-compatible server, or when a cloud model's key is missing.
    Answered from LiteLLM's cost map without importing LiteLLM where it can be (`model_names`), else
    imports LiteLLM (seconds)."""
    if is_offline(model) or api_base:
        return
    from robocog.agent.client.model_names import quick_verdict, unknown_model

    verdict, problem = quick_verdict(model, api_key)  # most answers, without importing LiteLLM (seconds)
    if problem:
        raise ConfigError(problem)
    if verdict == "ok":
        return
    from robocog.agent.client.model import check_credentials, configured_litellm
    from robocog.shared.errors import ModelServiceError

    litellm = configured_litellm()
    try:
        litellm.get_llm_provider(model)
    except Exception:
        names = [str(n) for n in getattr(litellm, "model_cost", {}) if "/" not in str(n)]
        raise ConfigError(unknown_model(model, names)) from None
    try:
        check_credentials(model, api_base, api_key)
    except ModelServiceError as exc:
        raise ConfigError(str(exc)) from None


def free_viewer_port(port: int) -> int:
    """The live viewer's port: `port` if nothing listens on it, a free one for 0; `ConfigError` if taken."""
    got, why = probe_bind("127.0.0.1", port)
    if why:
        raise ConfigError(
            f"--view {port}: 127.0.0.1:{port} is already in use ({why}); give another port, or --view 0 for a free one"
        )
    return got


def memory_dir(data_dir: str | None) -> Path:
    """Where a spawned server keeps its embedded memory: --data-dir, $ROBOCOG_DATA_DIR, or the per-user dir."""
    from robocog.shared.memory_names import default_data_dir

    given = data_dir or os.environ.get("ROBOCOG_DATA_DIR")
    return Path(given).expanduser() if given else default_data_dir()


def memory_records(directory: Path, namespace: str) -> int | None:
    """How many records the namespace holds in the embedded memory at `directory` (0 when there is
    none yet; None when it cannot be read). Read from ChromaDB's SQLite file, without ChromaDB."""
    from robocog.shared.memory_names import collection_name

    database = directory / "chroma.sqlite3"
    if not database.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{database}?mode=ro", uri=True, timeout=2) as db:
            row = db.execute(
                "SELECT count(e.id) FROM collections c JOIN segments s ON s.collection = c.id "
                "JOIN embeddings e ON e.segment_id = s.id WHERE c.name = ? AND s.scope = 'METADATA'",
                (collection_name(namespace),),
            ).fetchone()
    except (sqlite3.Error, ValueError):
        return None
    return int(row[0]) if row else 0


def memory_line(data_dir: str | None, namespace: str | None, server_cmd: str | None) -> str:
    """The line a run starts with: which memory the spawned server uses and how many records it holds."""
    directory = memory_dir(data_dir)
    space = namespace or "default"
    if server_cmd and "--memory-url" in server_cmd:
        return f"robocog: memory: the Chroma server named in --server-cmd, namespace {space}"
    count = memory_records(directory, space)
    held = "an unknown number of records" if count is None else f"{count} record{'s' if count != 1 else ''}"
    fresh = " (to start clean: --memory-namespace NEW-NAME, or --data-dir EMPTY-DIR)" if count else ""
    return f"robocog: memory: {directory}, namespace {space}: {held} from earlier runs{fresh}"
