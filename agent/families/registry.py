"""The registry of the suite's task families: each family's draws (how the suite generator draws a
variant's parameters) and prompt readers (how the scripted planner reads its prompts), registered
by the family module that defines them, with the decorators `draw` and `reader`.

**Where a draw's name is spelled.** Once: in its `@draw(name, gives=..., takes=...)`, beside its
code. The declaration (`robocog.shared.family_files.DrawSpec`: the parameters it gives, each with an
example value of its shape, and the variant fields it takes: count, choices, prelude) lives with
the implementation, not in `robocog.shared`, because `shared` cannot import `agent`: a family that
brings a new draw would otherwise have to edit `shared/suite.py` as well. So `shared` checks a family
file against the declarations its caller passes in (`robocog.shared.family_files.load_family(path, draws)`),
and this package's `load_family` / `load_families` pass every registered one (`draw_specs()`): a
variant's draw must be registered, its templates may use only the parameters the draw gives, and
it has a count, choices or a prelude exactly when its draw takes one.

**The order in which the planner reads a prompt.** `understand` (`robocog.agent.policies.belief`)
asks the readers in ascending `order`; the first whose pattern matches the task (cleaned: lower
case, no leading article) reads it, and its answer is final (None: the planner does not know how).
Today's order, which a test holds:

| order | family    | pattern (on the cleaned task)                       | reads the prompts of              |
|-------|-----------|-----------------------------------------------------|-----------------------------------|
| 10    | memory    | "put / bring / take / move / return X back"         | memory (where memory says X was)  |
| 20    | swap      | "swap X and Y"                                      | swap                              |
| 25    | long_hor. | "tidy the house: X on P, Y on Q, ..."               | long_horizon                      |
| 30    | rearrange | "(re)arrange ...: X on P, Y on Q"                   | rearrange                         |
| 35    | containers| "put X into C", "take X out of C ...", "bring X     | containers (C a drawer, cabinet   |
|       |           | from C to L" (C ends in drawer / cabinet / fridge)  | or fridge)                        |
| 40    | bring     | "put / place / ... / bring / take / move / get ..." | bring, put_away, referring,       |
|       |           |                                                     | infeasible                        |
| 50    | search    | "find X and bring / put it to / on P"               | search                            |

Put away, referring and infeasible register draws only: their prompts are transport prompts, which
the bring family's reader reads (it owns them: bring is the suite's baseline). Draw helpers shared
between families live in the family that owns them (`bring.other_location`,
`put_away.choose_furniture`), and the phrase grounding all readers share in
`robocog.agent.families.reading`.

**Adding a family** is two files, nothing else:
1. `assets/families/ID.yaml`: its variants, each naming a draw (see `robocog.shared.suite`); list it
   in a suite's `suite.yaml` to generate instances of it.
2. `agent/families/ID.py`: with `@draw("name", gives={"param": example}, takes=(...))` on each new
   draw function (a variant may also use another family's draw), and, if no reader understands its
   prompts yet, `@reader(r"^pattern", order=N)` on a function that turns the match into a `Request`
   (pick N by where it must sit in the table above). The package imports every module in it when it
   is first imported, so the module's decorators register it; no list names it.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from robocog.agent.families.reading import FirstLook, Request
from robocog.agent.symbolic.world import SceneNames, Where
from robocog.shared.family_files import DrawSpec, Takes, Variant

#: A draw: from the seeded generator, the scene's names, where every object starts and the variant,
#: the variant's parameters (each one its `DrawSpec` gives), or None when this start cannot pose it.
DrawFunction = Callable[[random.Random, SceneNames, Where, Variant], dict[str, Any] | None]
#: A prompt reader: from its pattern's match on the cleaned task, the first look around and what
#: search_memory found, the request (None: the task is of its kind, but the planner cannot read it).
ReadFunction = Callable[[re.Match[str], FirstLook, list[dict[str, Any]]], Request | None]

D = TypeVar("D", bound=DrawFunction)
R = TypeVar("R", bound=ReadFunction)


@dataclass(frozen=True)
class RegisteredDraw:
    """A draw as registered: its declaration, its function and the family (module) that defines it."""

    spec: DrawSpec
    make: DrawFunction
    family: str


@dataclass(frozen=True)
class PromptReader:
    """A prompt reader as registered: where it sits in the reading order, what it matches, its function
    and the family (module) that defines it."""

    order: int
    pattern: re.Pattern[str]
    read: ReadFunction
    family: str


_DRAWS: dict[str, RegisteredDraw] = {}
_READERS: list[PromptReader] = []


def _family_of(function: Callable[..., Any]) -> str:
    """The family a function belongs to: the name of its module in this package."""
    return function.__module__.rpartition(".")[2]


def draw(name: str, *, gives: Mapping[str, Any], takes: Iterable[Takes] = ()) -> Callable[[D], D]:
    """Register the decorated function as the draw `name`, which gives the parameters `gives` (name ->
    an example value of its shape) and takes the variant fields `takes`."""

    def register(function: D) -> D:
        if name in _DRAWS:
            raise ValueError(f"draw {name!r} is registered twice ({_DRAWS[name].family}, {_family_of(function)})")
        spec = DrawSpec(name=name, gives=dict(gives), takes=frozenset(takes))
        _DRAWS[name] = RegisteredDraw(spec=spec, make=function, family=_family_of(function))
        return function

    return register


def reader(pattern: str, *, order: int) -> Callable[[R], R]:
    """Register the decorated function as the prompt reader of the tasks that match `pattern` (a
    regular expression, matched at the start of the cleaned task), asked at `order` (ascending)."""

    def register(function: R) -> R:
        clash = next((r for r in _READERS if r.order == order), None)
        if clash is not None:
            raise ValueError(f"reader order {order} is taken ({clash.family}, {_family_of(function)})")
        _READERS.append(PromptReader(order, re.compile(pattern), function, _family_of(function)))
        _READERS.sort(key=lambda r: r.order)
        return function

    return register


def registered_draws() -> dict[str, RegisteredDraw]:
    """Every registered draw, by name, in registration order."""
    return dict(_DRAWS)


def draw_specs() -> dict[str, DrawSpec]:
    """Every registered draw's declaration, by name: what `robocog.shared.family_files.load_family` checks."""
    return {name: d.spec for name, d in _DRAWS.items()}


def draw_function(name: str) -> DrawFunction:
    """The function of the registered draw `name`."""
    return _DRAWS[name].make


def prompt_readers() -> list[PromptReader]:
    """Every registered prompt reader, in the order the planner asks them."""
    return list(_READERS)
