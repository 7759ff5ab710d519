"""The record `robocog submit verify` leaves beside a submission or a results file
(`NAME.replay.json`): for each row, whether its replay in the physics gave its verdict, tied to the
file by the sha256 of its bytes.

`robocog leaderboard` reads it beside each submission it is given (within the bounds of
`robocog.agent.analysis.untrusted`): a submission's row is verified only when its replay matched
(`statuses`). A record of other bytes (the submission changed after it was verified) counts as none.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robocog.agent.analysis.untrusted import SUBMISSION_BYTES, Refused, read_bounded, read_json

FORMAT = "robocog-replay/1"
#: A row's replay: it gave the row's verdict; it did not; nothing to replay (an errored attempt, an
#: instance not run); or it could not be replayed (no trace).
STATUSES = ("matches", "differs", "skipped", "missing")


def record_path(submission: Path) -> Path:
    return submission.with_name(submission.stem + ".replay.json")


def file_sha256(path: Path) -> str:
    """The sha256 of a submission's (or a results file's) bytes."""
    return hashlib.sha256(read_bounded(path, SUBMISSION_BYTES, "study")).hexdigest()


def write_record(submission: Path, out: Path, rows: Sequence[dict[str, Any]], meta: dict[str, Any]) -> None:
    """Write the replay record of `submission` (one entry per row: `row`, `status`, `differs`)."""
    body = {"format": FORMAT, "submission": submission.name, "submission_sha256": file_sha256(submission)}
    out.write_text(json.dumps(body | meta | {"rows": list(rows)}, indent=1) + "\n", encoding="utf-8")


def statuses(submission: Path, rows: int) -> tuple[str, ...] | None:
    """Each row's replay status from the record beside `submission` (None: no record, or a record of
    other bytes); a record that is not one is refused (`Refused`)."""
    path = record_path(submission)
    if not path.exists():
        return None
    data = read_json(path, what="replay record")
    entries = data.get("rows") if isinstance(data, dict) else None
    if not isinstance(data, dict) or data.get("format") != FORMAT or not isinstance(entries, list):
        raise Refused(f"{path}: not a replay record of robocog submit verify")
    if data.get("submission_sha256") != file_sha256(submission):
        return None
    out = ["missing"] * rows
    for entry in entries:
        number = entry.get("row") if isinstance(entry, dict) else None
        status = entry.get("status") if isinstance(entry, dict) else None
        if not isinstance(number, int) or not 1 <= number <= rows or status not in STATUSES:
            raise Refused(f"{path}: an entry is not a row's replay: {str(entry)[:80]}")
        out[number - 1] = status
    return tuple(out)
