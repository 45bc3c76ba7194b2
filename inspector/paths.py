"""Which files the inspector may read: the pairs it was given and the data roots.

Every path that comes from the browser (a pair chosen in the dropdown, a folder typed in)
is resolved (symbolic links followed, ``..`` removed) and must then lie inside one of the
allowed folders, or be one of the allowed files. A symbolic link inside a data root that
points outside it is therefore refused, as is ``root/../elsewhere``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

from radcons.errors import InputError
from radcons.io import MANIFEST

__all__ = ["AllowedRoots", "PairSource", "pair_sources"]


@dataclass(frozen=True)
class PairSource:
    """Where a pair comes from: a pair folder, or a reference and a target image.

    Attributes
    ----------
    label : str
        Name shown in the pair dropdown.
    folder : Path or None
        The pair folder (holding ``pair.toml``).
    files : tuple of Path
        ``(reference, target)`` when the pair is two loose images; empty otherwise.
    given : bool
        Named on the command line (True) or found under a data root (False).
    """

    label: str
    folder: Path | None = None
    files: tuple[Path, ...] = ()
    given: bool = True


class AllowedRoots:
    """The folders and files the inspector may read, all resolved once at start.

    Parameters
    ----------
    folders : iterable of path-like
        Folders whose whole tree may be read (data roots, pair folders).
    files : iterable of path-like
        Single files that may be read (a reference and a target given as images).

    Raises
    ------
    InputError
        A folder or file that does not exist.
    """

    def __init__(self, folders: Iterable[str | os.PathLike], files: Iterable[str | os.PathLike] = ()) -> None:
        self.folders: tuple[Path, ...] = tuple(_existing(path, folder=True) for path in folders)
        self.files: tuple[Path, ...] = tuple(_existing(path, folder=False) for path in files)

    def check(self, path: str | os.PathLike) -> Path:
        """Return ``path`` resolved, or raise when it lies outside the allowed roots.

        Parameters
        ----------
        path : path-like
            A folder or file named by the user.

        Returns
        -------
        Path
            The resolved path.

        Raises
        ------
        InputError
            The path does not exist, or resolves outside every allowed folder and is not
            an allowed file.
        """
        raw = Path(path).expanduser()
        try:
            resolved = raw.resolve(strict=True)
        except (OSError, RuntimeError) as exc:
            raise InputError("no such file or folder", raw) from exc
        if resolved in self.files or any(resolved == root or root in resolved.parents for root in self.folders):
            return resolved
        raise InputError("outside the folders this inspector may read (its pairs and --data-root)", raw)

    def discover_pairs(self, max_depth: int = 3, limit: int = 500) -> list[Path]:
        """Return the pair folders (folders holding ``pair.toml``) under the allowed folders.

        Parameters
        ----------
        max_depth : int
            How many folder levels below each root are searched.
        limit : int
            Stop after this many pairs.

        Returns
        -------
        list of Path
            Resolved folders, sorted, each inside the allowed roots (links that lead
            outside are skipped).
        """
        found: set[Path] = set()
        for root in self.folders:
            for folder in _walk(root, max_depth):
                if (folder / MANIFEST).is_file():
                    try:
                        found.add(self.check(folder))
                    except InputError:
                        continue
                if len(found) >= limit:
                    return sorted(found)
        return sorted(found)


def _existing(path: str | os.PathLike, folder: bool) -> Path:
    resolved = Path(path).expanduser().resolve()
    if folder and not resolved.is_dir():
        raise InputError("not a folder", path)
    if not folder and not resolved.is_file():
        raise InputError("not a file", path)
    return resolved


def _walk(root: Path, max_depth: int) -> Iterable[Path]:
    """Yield ``root`` and its sub-folders down to ``max_depth`` levels (hidden ones skipped)."""
    level = [root]
    for _ in range(max_depth + 1):
        following: list[Path] = []
        for folder in level:
            yield folder
            try:
                children = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
            except OSError:
                continue
            following.extend(children)
        level = following


def pair_sources(pairs: Sequence[str | os.PathLike], data_roots: Sequence[str | os.PathLike]) -> tuple[AllowedRoots, list[PairSource]]:
    """Turn the command line's pairs and data roots into allowed roots and a pair list.

    Parameters
    ----------
    pairs : sequence of path-like
        Pair folders, or image files taken two at a time as (reference, target).
    data_roots : sequence of path-like
        Folders whose pair folders are offered too.

    Returns
    -------
    roots : AllowedRoots
    sources : list of PairSource
        The pairs given, then those found under the data roots, without repeats.

    Raises
    ------
    InputError
        A path that does not exist, or an odd number of image files.
    """
    folders = [Path(p) for p in pairs if Path(p).is_dir()]
    files = [Path(p) for p in pairs if not Path(p).is_dir()]
    for path in files:
        if not path.is_file():
            raise InputError("no such pair folder or image file", path)
    if len(files) % 2:
        raise InputError("image files come in twos: a reference and a target", files[-1])
    roots = AllowedRoots([*folders, *data_roots], files)
    sources: list[PairSource] = []
    seen: set[Path] = set()
    for folder in folders:
        resolved = folder.resolve()
        seen.add(resolved)
        sources.append(PairSource(resolved.name, folder=resolved))
    for reference, target in zip(files[::2], files[1::2]):
        sources.append(PairSource(f"{reference.name} + {target.name}", files=(reference.resolve(), target.resolve())))
    for folder in roots.discover_pairs():
        if folder not in seen:
            seen.add(folder)
            sources.append(PairSource(_relative_label(folder, roots.folders), folder=folder, given=False))
    return roots, sources


def _relative_label(folder: Path, roots: Sequence[Path]) -> str:
    for root in roots:
        if root in folder.parents:
            return f"{root.name}/{folder.relative_to(root)}"
    return folder.name
