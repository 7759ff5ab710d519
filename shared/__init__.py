"""What the server and the client both import: pydantic schemas of tool results, tasks and traces."""

from typing import Any


def __getattr__(name: str) -> Any:
    """`__version__`, read from the installed package's metadata on first use (importlib.metadata
    costs about 0.2 s to import, which `robocog --help` need not pay)."""
    if name != "__version__":
        raise AttributeError(f"module 'robocog.shared' has no attribute {name!r}")
    from importlib import metadata

    try:
        version = metadata.version("robocog")
    except metadata.PackageNotFoundError:  # running from a source tree that is not installed
        version = "0.0.0"
    globals()["__version__"] = version
    return version
