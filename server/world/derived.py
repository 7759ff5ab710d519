"""Files the world derives from its assets at run time (the arm's URDF and its meshes): written to
one directory under the temporary directory, each named by its source's stem and a digest of what
it is made from, so a name stands for one content and a file made once serves every process after.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path


def derived_path(stem: str, made_from: bytes, suffix: str) -> Path:
    """Where a file derived from `made_from` (a source's bytes, with how it is derived) is written."""
    digest = hashlib.sha256(made_from).hexdigest()[:16]
    return Path(tempfile.gettempdir()) / "robocog-urdf" / f"{stem}-{digest}{suffix}"


def write_once(target: Path, data: bytes) -> Path:
    """`data` at `target` unless it is there already (atomically: parallel workers never see half a file)."""
    if not target.exists():
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(f".{id(data)}.tmp")
        tmp.write_bytes(data)
        tmp.replace(target)
    return target
