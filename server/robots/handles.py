"""Robot handles: minted and checked by the server (HMAC-signed), without the MCP SDK, so that the
router, which imports no SDK, checks them too (a handle it has not seen signed is not counted).

A handle is `ORIGIN.TOKEN.MAC`: ORIGIN names the fleet process that minted it (a router sends its
later calls there), TOKEN is random and MAC signs both with the server's secret (a router gives its
processes one, `ROBOCOG_DRIVER_SECRET`; without it, a random one per process).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets

from robocog.server.config import DRIVER_SECRET_ENV

#: The environment variable that gives a server its handle-signing secret.
SECRET_ENV = DRIVER_SECRET_ENV


class DriverIds:
    """Issues and checks driver ids: `ORIGIN.TOKEN.MAC`, where ORIGIN names the fleet process that
    issued it (a router sends the id's later calls there), TOKEN is random and MAC signs both."""

    def __init__(self, secret: bytes | None = None, origin: str = "0") -> None:
        if secret is None:
            shared = os.environ.get(SECRET_ENV)
            secret = shared.encode() if shared else secrets.token_bytes(32)
        self._secret = secret
        self.origin = origin

    def _mac(self, body: str) -> str:
        return hmac.new(self._secret, body.encode(), hashlib.sha256).hexdigest()[:32]

    def issue(self) -> str:
        body = f"{self.origin}.{secrets.token_urlsafe(18)}"
        return f"{body}.{self._mac(body)}"

    def valid(self, value: object) -> bool:
        if not isinstance(value, str) or len(value) > 200 or value.count(".") != 2:
            return False
        body, _, mac = value.rpartition(".")
        return hmac.compare_digest(mac, self._mac(body))


def fingerprint(driver_id: str) -> str:
    """What messages show of an id: enough to tell two apart, not enough to use one."""
    return hashlib.sha256(driver_id.encode()).hexdigest()[:8]
