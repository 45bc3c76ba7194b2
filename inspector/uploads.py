"""Images uploaded from the browser, kept in a private temporary folder until their pair is
complete.

The folder is made at the first upload (an inspector that never receives one leaves
nothing in the temporary folder) and removed when the inspector stops. Each image is
checked by its size, its name and by reading it with the readers of any input; a complete
pair is moved to a folder of its own, so that it can be opened again later.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from radcons.errors import InputError
from radcons.io import is_image_file, read_raster
from radcons.io.raster import SUPPORTED_TEXT

__all__ = ["Uploads", "UploadedPair", "UPLOAD_SUFFIXES", "UPLOAD_TYPES", "ROLES"]

#: Image files accepted as uploads (formats that hold their image in one file).
UPLOAD_SUFFIXES: tuple[str, ...] = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".jp2", ".j2k", ".ntf", ".nitf")
#: The upload buttons' ``accept`` list.
UPLOAD_TYPES = "image/png,image/tiff,image/jpeg,image/jp2," + ",".join(UPLOAD_SUFFIXES)
#: The two images of a pair, in order.
ROLES: tuple[str, str] = ("reference", "target")


@dataclass(frozen=True)
class UploadedPair:
    """Two uploaded images that make a pair.

    Attributes
    ----------
    reference, target : Path
        The files, in a folder of their own.
    names : (str, str)
        Their names as uploaded.
    """

    reference: Path
    target: Path
    names: tuple[str, str]


class Uploads:
    """Uploaded images waiting for the other image of their pair.

    Parameters
    ----------
    max_bytes : int
        Largest accepted upload per image.

    Attributes
    ----------
    waiting : dict
        Role (``"reference"`` or ``"target"``) -> the file of an image received.
    names : dict
        Role -> the name the image was uploaded as.
    """

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = max_bytes
        self.waiting: dict[str, Path] = {}
        self.names: dict[str, str] = {}
        self._root: Path | None = None
        self._pairs = 0

    def _folder(self) -> Path:
        """The private folder, made at the first upload."""
        if self._root is None:
            self._root = Path(tempfile.mkdtemp(prefix="radcons-uploads-"))
        return self._root

    def receive(self, role: str, name: str, content: bytes) -> UploadedPair | None:
        """Check and keep an uploaded image; the pair once both images are in.

        Raises
        ------
        InputError
            Too large, not an image file name radcons reads, or not readable as an image
            (the role's earlier image, if any, is dropped too).
        """
        name = Path(name or "").name
        suffix = Path(name).suffix.lower()
        self.waiting.pop(role, None)
        folder = self._folder()
        for old in folder.glob(f"{role}.*"):
            old.unlink()
        if len(content) > self.max_bytes:
            raise InputError(f"{len(content) / 2**20:.1f} MiB is over the {self.max_bytes // 2**20} MiB limit", name)
        if suffix not in UPLOAD_SUFFIXES or not is_image_file(Path(name)):
            raise InputError(f"unsupported file type {suffix or '(none)'!r} ({SUPPORTED_TEXT})", name)
        path = folder / f"{role}{suffix}"
        path.write_bytes(content)
        try:
            read_raster(path)
        except InputError:
            path.unlink()
            raise
        self.waiting[role] = path
        self.names[role] = name
        if len(self.waiting) < len(ROLES):
            return None
        self._pairs += 1
        kept = folder / f"pair-{self._pairs}"
        kept.mkdir()
        reference, target = (self.waiting[role].replace(kept / self.waiting[role].name) for role in ROLES)
        self.waiting = {}
        return UploadedPair(reference, target, (self.names["reference"], self.names["target"]))

    def describe(self) -> str:
        """What is waiting for its pair, in words ("" when nothing is)."""
        parts = [f"{role}: {self.names[role]}" for role in ROLES if role in self.waiting]
        return ("Received " + ", ".join(parts) + "; waiting for the other image.") if parts else ""

    def remove(self) -> None:
        """Delete every uploaded file and the folder."""
        if self._root is not None:
            shutil.rmtree(self._root, ignore_errors=True)
            self._root = None
