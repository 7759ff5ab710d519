"""What the server and the client both import: pydantic schemas of tool results, tasks and traces."""

from importlib import metadata

try:
    __version__ = metadata.version("robocog")
except metadata.PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0"
