"""Config files as data: YAML read into strict pydantic models, every problem one line.

`load_yaml_model` reads a file and validates it as a model; a malformed file raises `ConfigError`
naming the file, the field and the problem on one line (`scene.yaml: edges[7]: 'Attic' is not a
location`). `STRICT_CONFIG` is the files' models' configuration (unknown fields are errors, frozen,
finite numbers only), and `Vec2`, `Vec3`, `Rgba` and `Positive` the field types they share.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from pydantic_core import ErrorDetails

from robocog.shared.errors import ConfigError

#: libyaml's safe loader where PyYAML was built with it (its wheels are), else None.
_FAST_LOADER = getattr(yaml, "CSafeLoader", None)

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Rgba = tuple[float, float, float, float]
Positive = Annotated[float, Field(gt=0)]
M = TypeVar("M", bound=BaseModel)


#: A config file's model: unknown fields are errors, values are frozen, numbers finite.
STRICT_CONFIG = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


#: Most pydantic problems one error line lists before "and N more".
_MAX_PROBLEMS = 3
# A model validator's message that starts with the field it is about: "edges[7]: ..." or
# "objects[0] (cube): ...".
_FIELD_FIRST = re.compile(r"^[A-Za-z_]\w*(\[\d+\])*(\.[A-Za-z_]\w*(\[\d+\])*)*( \([^()]*\))?: ")


def field_path(loc: tuple[int | str, ...]) -> str:
    """A pydantic location as the file's field: ("edges", 7, "x") -> "edges[7].x"."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else f".{part}" if out else str(part)
    return out


def _problem(err: ErrorDetails) -> str:
    """One pydantic error as "field: problem"; a model validator's "field: problem" keeps its field."""
    where = field_path(err["loc"])
    msg = err["msg"]
    if err["type"] == "value_error":
        msg = msg.removeprefix("Value error, ")
        if _FIELD_FIRST.match(msg):
            return f"{where}.{msg}" if where else msg
    return f"{where}: {msg}" if where else msg


def validation_problems(exc: ValidationError) -> str:
    """A pydantic `ValidationError` as one line: "field: problem; field: problem"."""
    problems = [_problem(err) for err in exc.errors()]
    more = len(problems) - _MAX_PROBLEMS
    return "; ".join(problems[:_MAX_PROBLEMS]) + (f"; and {more} more" if more > 0 else "")


def _non_finite(data: Any, where: str = "") -> str | None:
    """The field of the first NaN or infinite number in YAML data (`.nan`, `.inf`), if any."""
    seen: set[int] = set()  # YAML aliases share nodes: visit each container once
    stack: list[tuple[Any, str]] = [(data, where)]
    while stack:
        node, at = stack.pop()
        if isinstance(node, float) and not math.isfinite(node):
            return at
        if isinstance(node, dict | list) and id(node) not in seen:
            seen.add(id(node))
            items = node.items() if isinstance(node, dict) else enumerate(node)
            children = [(v, f"{at}[{k}]" if isinstance(k, int) else f"{at}.{k}" if at else str(k)) for k, v in items]
            stack.extend(reversed(children))
    return None


def inside(path: Path, roots: Sequence[Path]) -> bool:
    """Whether `path`, its links followed, lies in one of the folders `roots` (theirs followed too)."""
    try:
        real = path.resolve()
    except (OSError, RuntimeError):  # a loop of links
        return False
    return any(real.is_relative_to(root.resolve()) for root in roots)


def read_yaml(path: Path, max_bytes: int | None = None) -> Any:
    """The YAML data of `path`; `ConfigError` (one line: file, where, problem) when it cannot be read,
    or when it is longer than `max_bytes`."""
    try:
        if max_bytes is not None and path.stat().st_size > max_bytes:
            raise ConfigError(
                f"{path}: {path.stat().st_size:,} bytes, more than the {max_bytes:,} such a file may have"
            )
        raw = path.read_bytes()
    except FileNotFoundError as exc:
        raise ConfigError(f"{path}: file not found") from exc
    except IsADirectoryError as exc:
        raise ConfigError(f"{path}: is a directory, not a file") from exc
    except OSError as exc:
        raise ConfigError(f"{path}: cannot be read: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"{path}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x}); save the file as UTF-8"
        ) from exc
    if _FAST_LOADER is not None and "\t" not in text:  # PyYAML refuses a tab in a plain scalar; libyaml not
        try:  # libyaml's parser: the same values, about eight times faster (a scene is most of a world's build)
            return yaml.load(text, Loader=_FAST_LOADER)  # CSafeLoader: the safe loader
        except (yaml.YAMLError, RecursionError):
            pass  # the pure-Python parser below says what is wrong, in its own words
    try:
        return yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = exc.problem or exc.context or "syntax error"
        raise ConfigError(f"{path}: {where}not valid YAML: {problem}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from exc
    except RecursionError as exc:
        raise ConfigError(f"{path}: not valid YAML: nested too deeply") from exc


def load_yaml_model(
    path: Path, model: type[M], max_bytes: int | None = None, overrides: dict[str, Any] | None = None
) -> M:
    """Read `path` as YAML and validate it as `model`, with the fields of `overrides` in place of the
    file's (a command line's); errors name the file, the field and the problem.

    Every error is one line, `FILE: FIELD: problem` (`FILE: line L, column C: ...` for YAML syntax); a
    file longer than `max_bytes` is refused before it is read.
    """
    data = read_yaml(path, max_bytes)
    if not isinstance(data, dict):
        got = "an empty file" if data is None else f"a {type(data).__name__}"
        raise ConfigError(f"{path}: expected a mapping of fields (name: value), got {got}")
    data = {**data, **(overrides or {})}
    bad = _non_finite(data)
    if bad is not None:
        raise ConfigError(f"{path}: {bad}: must be a finite number, not NaN or infinity")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"{path}: {validation_problems(exc)}") from exc
