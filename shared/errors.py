"""Every error robocog raises on purpose: one base class and the few kinds a caller catches.

A failure a model could have avoided (an unknown object, an occupied position) is not an error:
tools report it as a result with `status: "failure"`. These are for the program's users.
"""

from __future__ import annotations


class RobocogError(Exception):
    """Base class of robocog's own errors."""


class ConfigError(RobocogError, ValueError):
    """A scene, robot, task or study file, or a command-line value, is invalid (names file and field)."""


class WorldError(RobocogError):
    """The simulated world cannot be built or driven as asked."""


class ModelServiceError(RobocogError):
    """The model service failed: no credentials, refused, or kept failing past the retries."""


class ServerConnectionError(RobocogError):
    """The robot server could not be started or reached, or failed while serving a call."""


class MemoryStorageError(ServerConnectionError):
    """The robot server's episodic memory cannot be written or read (a full disk, a read-only or removed
    database): the attempt errs with the reason, and no retry on that server helps."""
