"""Memory names and addresses, light to import: the server checks them before loading ChromaDB."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import urlsplit

#: Prefix of every collection robocog creates; the namespace follows it.
COLLECTION_PREFIX = "robocog-"
# Chroma's collection-name rule (3-63 chars, alphanumeric ends, [A-Za-z0-9._-] inside, no "..").
_NAMESPACE_RE = re.compile(r"^[A-Za-z0-9](?:[A-Za-z0-9._-]*[A-Za-z0-9])?$")
_MAX_NAMESPACE = 63 - len(COLLECTION_PREFIX)


def collection_name(namespace: str) -> str:
    """The Chroma collection that holds ``namespace``; ``ValueError`` if the namespace is invalid."""
    if (
        not isinstance(namespace, str)
        or not 1 <= len(namespace) <= _MAX_NAMESPACE
        or not _NAMESPACE_RE.match(namespace)
        or ".." in namespace
    ):
        raise ValueError(
            f"invalid memory namespace {namespace!r}: use 1-{_MAX_NAMESPACE} characters from "
            "letters, digits, '.', '_' and '-', starting and ending with a letter or digit, "
            "with no '..' (e.g. 'default' or 'kitchen-robot-1')"
        )
    return COLLECTION_PREFIX + namespace


def parse_chroma_url(url: str) -> tuple[str, int, bool]:
    """Split ``http(s)://host[:port]`` into ``(host, port, ssl)``; ``ValueError`` if malformed.

    The port defaults to 8000 (Chroma's) for http and 443 for https.
    """
    example = "expected a Chroma server URL like 'http://localhost:8000' or 'https://chroma.example:443'"
    try:
        parts = urlsplit(url.strip())
        port = parts.port
    except (ValueError, AttributeError) as e:
        raise ValueError(f"malformed Chroma URL {url!r}: {e}; {example}") from e
    if parts.scheme not in ("http", "https"):
        raise ValueError(f"malformed Chroma URL {url!r}: scheme must be http or https; {example}")
    if not parts.hostname:
        raise ValueError(f"malformed Chroma URL {url!r}: no host; {example}")
    if parts.username or parts.password or parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(
            f"malformed Chroma URL {url!r}: only scheme, host and port are allowed "
            f"(no credentials, path, query or fragment); {example}"
        )
    ssl = parts.scheme == "https"
    return parts.hostname, port if port is not None else (443 if ssl else 8000), ssl


def default_data_dir() -> Path:
    """Where embedded memory lives when no ``data_dir`` is given."""
    import platformdirs

    return Path(platformdirs.user_data_dir("robocog")) / "memory"
