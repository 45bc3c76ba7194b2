"""Input paths checked before they are read: existing regular files, files inside a folder.

A symbolic link loop, a broken link, a folder or a device given where an image belongs is
named as such (one line, exit status 2 on the command line), not left to fail later.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from radcons.errors import InputError

__all__ = ["check_input_file", "file_inside", "NOT_FOUND"]

#: The reason :func:`check_input_file` gives for a path that does not exist.
NOT_FOUND = "file not found"


def check_input_file(path: str | Path) -> Path:
    """Return ``path`` when it is an existing regular file (links followed), else raise.

    Parameters
    ----------
    path : str or Path
        A file to read.

    Returns
    -------
    Path
        ``path``, unchanged.

    Raises
    ------
    InputError
        A symbolic link loop, a broken symbolic link, a missing file, an unreadable
        folder on the way, a folder, or anything but a regular file.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError("a symbolic link loop: following its links never reaches a file", path) from exc
        if exc.errno == errno.EACCES:
            raise InputError("permission denied", path) from exc
        if os.path.islink(path):
            raise InputError("a broken symbolic link: the file it points to does not exist", path) from exc
        raise InputError(NOT_FOUND, path) from exc
    if stat.S_ISDIR(info.st_mode):
        raise InputError("a folder, not a file", path)
    if not stat.S_ISREG(info.st_mode):
        raise InputError("not a regular file", path)
    return path


def file_inside(folder: Path, value: str, where: Path, key: str) -> Path:
    """The file a manifest's ``key = value`` names, checked to lie inside ``folder``.

    Parameters
    ----------
    folder : Path
        The pair folder holding the manifest.
    value : str
        The file name as written in the manifest, relative to ``folder``.
    where : Path
        The manifest, named in errors.
    key : str
        The manifest key, named in errors.

    Returns
    -------
    Path
        The file, resolved (links followed), inside ``folder``.

    Raises
    ------
    InputError
        ``value`` is absolute, climbs out of ``folder`` (``..``), is or passes a symbolic
        link that leads out of it, or does not name an existing regular file.
    """
    root = folder.resolve()
    named = root / value
    if Path(value).is_absolute() or root not in Path(os.path.normpath(named)).parents:
        raise InputError(
            f"{key} = {value!r} points outside the pair folder {root} (a manifest names files inside its folder)",
            where,
        )
    try:
        check_input_file(named)
    except InputError as exc:
        missing = exc.reason == NOT_FOUND
        message = f"{key} names a missing file {value!r}" if missing else f"{key} = {value!r}: {exc.reason}"
        raise InputError(message, where) from exc
    resolved = named.resolve()
    if root not in resolved.parents:
        raise InputError(
            f"{key} = {value!r} is a symbolic link that leads outside the pair folder {root} (to {resolved})", where
        )
    return resolved
