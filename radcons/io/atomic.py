"""Writes that never leave a half file or a half folder behind.

Every file goes to a temporary file in its destination folder that is then renamed over
the destination; a folder of results is built beside its destination and swapped in whole.
"""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import tempfile
import uuid
from pathlib import Path
from typing import Iterator

__all__ = ["atomic_write_bytes", "staged_folder", "recover_folder", "temporary_beside"]


def temporary_beside(path: Path) -> tuple[int, str]:
    """Open a temporary file in ``path``'s folder with the permissions a plain open would give.

    Temporary files left beside ``path`` by an earlier write that was killed are removed
    first.
    """
    for stale in path.parent.glob(f".{glob.escape(path.name)}.*.part"):
        stale.unlink(missing_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)
    return fd, tmp


def atomic_write_bytes(path: str | Path, payload: bytes) -> None:
    """Write ``payload`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = temporary_beside(path)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _staging_names(out: Path, kind: str) -> list[Path]:
    return sorted(out.parent.glob(f".{glob.escape(out.name)}.{kind}-*"))


def recover_folder(out: str | Path) -> None:
    """Undo what a killed :func:`staged_folder` left beside ``out``.

    A run killed between moving the old result aside and moving the new one in leaves no
    ``out``: the old result is put back. Every other staging folder is removed.
    """
    out = Path(out)
    if not out.parent.is_dir():
        return
    olds = _staging_names(out, "old")
    if olds and not out.exists():
        os.replace(olds.pop(), out)
    for leftover in olds + _staging_names(out, "new"):
        shutil.rmtree(leftover, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(out: str | Path) -> Iterator[Path]:
    """Build a folder's new content beside it and swap it in whole at the end.

    Yields a temporary folder next to ``out`` (same file system); when the block ends
    without an error, the old ``out`` (if any) is moved aside, the new one renamed into
    place and the old one removed. On an error, or when the process is interrupted, the
    temporary folder is removed and ``out`` keeps its old, complete content; a process
    killed outright leaves staging folders that :func:`recover_folder` (called first
    here) clears on the next run.

    Parameters
    ----------
    out : str or Path
        The folder to write.

    Yields
    ------
    Path
        The folder to write into.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    recover_folder(out)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.new-", dir=out.parent))
    try:
        yield staging
        staging.chmod(0o777 & ~_umask())
        if out.exists():
            old = out.parent / f".{out.name}.old-{uuid.uuid4().hex[:12]}"
            os.replace(out, old)
            os.replace(staging, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask

