"""The exceptions of plexus, one per code of the C++ client's ErrorCode (the CLI's exit statuses)."""

from __future__ import annotations

import builtins


class Error(Exception):
    """Anything that went wrong in Plexus. ``code`` is the C++ ErrorCode (the CLI's exit status);
    the message is the one the CLI prints after ``plexus:``."""

    code = 0

    def __init__(self, message: str = "") -> None:
        super().__init__(message)
        self.message = message


class NotFoundError(Error, LookupError):
    """The daemon answered "no": what was asked about does not exist (code 1)."""

    code = 1


class UsageError(Error, ValueError):
    """The request was wrong: a bad port name, policy, carrier, a closed port... (code 2)."""

    code = 2


class TimeoutError(Error, builtins.TimeoutError):
    """The daemon (or a peer) did not answer in time (code 3). Also a builtins.TimeoutError."""

    code = 3


class RefusedError(Error, ConnectionError):
    """Refused: no daemon at the socket, a connect the daemon refused, a broken link (code 4)."""

    code = 4


for _cls in (Error, NotFoundError, UsageError, TimeoutError, RefusedError):
    _cls.__module__ = "plexus"  # tracebacks say plexus.UsageError, the name users import

_BY_CODE = {cls.code: cls for cls in (NotFoundError, UsageError, TimeoutError, RefusedError)}


def from_code(code: int, message: str) -> Error:
    """The exception for a C++ plexus::Error (called by the extension's exception translator)."""
    return _BY_CODE.get(code, Error)(message)
