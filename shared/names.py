"""How names are compared: the one name normaliser of robocog.

Wherever a name or a phrase is matched against the names of a scene (a model's tool arguments on
the server, a scene's descriptions, the scripted planner reading a task), it is first reduced to its
`name_key`: case does not matter, nor do runs of spaces, hyphens and underscores (one space), nor
punctuation around it (". , ; : ! ?"); articles ("the", "a", "an") are dropped as the caller asks:

- `articles="leading"` (the default): a leading article only: a referring expression or a phrase
  of a task ("The  drinking vessel." -> "drinking vessel");
- `articles="all"`: every article: a name given to a tool ("put it on the top" -> "put it on top");
- `articles="keep"`: none: exact matching of a known name ("Kitchen_Shelf" -> "kitchen shelf").
"""

from __future__ import annotations

import re
from typing import Literal

#: The words that never tell names apart.
ARTICLES = frozenset({"the", "a", "an"})
#: Which articles `name_key` drops.
Articles = Literal["keep", "leading", "all"]

_SEPARATORS = re.compile(r"[\s_\-]+")
_SURROUNDING = " .,;:!?"


def name_key(text: str, *, articles: Articles = "leading") -> str:
    """`text` as names are compared (see the module's docstring)."""
    words = _SEPARATORS.sub(" ", text).casefold().strip(_SURROUNDING).split()
    if articles == "all":
        words = [w for w in words if w not in ARTICLES]
    elif articles == "leading" and words and words[0] in ARTICLES:
        words = words[1:]
    return " ".join(words)
