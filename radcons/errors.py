"""Exception types raised by radcons.

Every error caused by the user's input is a :class:`RadconsError`; the command line
prints its message on one line and exits with status 2, without a traceback.
"""

from __future__ import annotations

from pathlib import Path


class RadconsError(Exception):
    """Base class of every error radcons reports to its user.

    Parameters
    ----------
    message : str
        What went wrong, in words a user can act on.
    path : str or Path, optional
        The file or folder the problem is about; it is prefixed to the message.
    """

    def __init__(self, message: str, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self.reason = message
        super().__init__(f"{self.path}: {message}" if self.path is not None else message)


class InputError(RadconsError):
    """An input image, pair folder or manifest is unreadable or unusable."""


class ParamsError(RadconsError):
    """A parameter file or value is invalid."""


class StageError(RadconsError):
    """A processing stage cannot run on the data it was given (e.g. no matches at all)."""
