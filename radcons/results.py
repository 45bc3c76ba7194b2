"""Result types: the plain values that stages return and the pipeline, recorder, CLI and inspector read.

Images inside radcons are float32 on the input's original value range with NaN where a
pixel is invalid (nodata). Points are ``(x, y)`` = (column, row) in pixels. Disparity
follows the project convention ``reference(x, y) <-> target(x - d, y)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

__all__ = [
    "Matches",
    "ObjectAssociation",
    "Association",
    "ObjectFit",
    "StageImages",
    "ObjectLabels",
]


@dataclass(frozen=True)
class Matches:
    """Sparse feature matches between the reference and the target.

    Attributes
    ----------
    ref_xy, tgt_xy : ndarray, shape (N, 2), float32
        Matched keypoint positions ``(x, y)`` in each image.
    """

    ref_xy: np.ndarray
    tgt_xy: np.ndarray

    def __len__(self) -> int:
        return int(self.ref_xy.shape[0])

    @property
    def disparity(self) -> np.ndarray:
        """Horizontal disparity ``x_ref - x_tgt`` of each match (float32)."""
        return (self.ref_xy[:, 0] - self.tgt_xy[:, 0]).astype(np.float32)

    @classmethod
    def empty(cls) -> "Matches":
        """No matches."""
        return cls(np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32))


@dataclass(frozen=True)
class ObjectAssociation:
    """One object of the reference associated with one object of the target (section 3).

    Attributes
    ----------
    ref_id, tgt_id : int
        Label ids in the reference and target label rasters.
    method : str
        ``"sift"`` (more than ``min_matches`` matches link them) or ``"template"``.
    modal_disparity : float
        D̄m, the most frequent disparity of the object's matches (or the template offset).
    match_indices : ndarray of int
        Indices into :class:`Matches` of the matches linking the two objects.
    invariant_indices : ndarray of int
        The subset of ``match_indices`` with ``|D_k - D̄m| < l`` (eq 12).
    score : float
        Template matching score (normalised cross-correlation) or NaN for SIFT.
    """

    ref_id: int
    tgt_id: int
    method: str
    modal_disparity: float
    match_indices: np.ndarray
    invariant_indices: np.ndarray
    score: float = float("nan")

    @property
    def n_matches(self) -> int:
        """Number of SIFT matches linking the two objects."""
        return int(self.match_indices.size)

    @property
    def n_invariant(self) -> int:
        """Number of invariant points (eq 12)."""
        return int(self.invariant_indices.size)


@dataclass(frozen=True)
class Association:
    """Result of object region association: the matches and the object pairs."""

    matches: Matches
    objects: tuple[ObjectAssociation, ...] = ()
    unassociated_ref: tuple[int, ...] = ()

    def by_ref(self) -> dict[int, ObjectAssociation]:
        """Associations keyed by reference object id."""
        return {obj.ref_id: obj for obj in self.objects}


@dataclass(frozen=True)
class ObjectFit:
    """Per-object linear fit of eq 7-11: ``reference ~ gain * target + offset``.

    Attributes
    ----------
    ref_id, tgt_id : int
        The associated object pair.
    gain, offset : float
        λ̂m and ζ̂m of eq 8.
    x, y : ndarray
        Target (x) and reference (y) grey values at the invariant points used.
    weights : ndarray
        τ_k of eq 11 for each point.
    applied : bool
        False when the object kept the global result (``note`` says why).
    clipped : int
        Points on clipped pixels (left out of a line fit).
    note : str
        Why the fit was not applied, or that it is an offset only (empty for an ordinary
        fit).
    """

    ref_id: int
    tgt_id: int
    gain: float
    offset: float
    x: np.ndarray
    y: np.ndarray
    weights: np.ndarray
    applied: bool
    clipped: int = 0
    note: str = ""

    @property
    def n_points(self) -> int:
        """Number of invariant points the fit used."""
        return int(self.x.size)

    @property
    def state(self) -> str:
        """``"applied"`` or ``"not applied"``, with the note, or else the clipped points
        left out (e.g. ``"not applied: too few points (2, min_points 3)"``)."""
        text = ("applied" if self.applied else "not applied") + (f": {self.note}" if self.note else "")
        if self.clipped and not self.note:
            text += f"; {self.clipped} points on clipped pixels left out"
        return text


@dataclass(frozen=True)
class StageImages:
    """The pair of images a stage produced, and its scalars.

    Attributes
    ----------
    reference, target : ndarray
        float32, original value range, NaN where invalid.
    info : Mapping
        Stage-specific values (e.g. ``{"A": ..., "lambda_reference": ...}`` for the global
        stage, ``{"fits": (ObjectFit, ...)}`` for the refined stage).
    """

    reference: np.ndarray
    target: np.ndarray
    info: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ObjectLabels:
    """Building objects of both images.

    Attributes
    ----------
    reference, target : ndarray of int32
        Label rasters, 0 = background.
    source : str
        ``"user"`` when the pair's own label rasters were used (they win over
        segmentation), ``"segmented"`` when :func:`radcons.stages.objects.mbi.extract_objects`
        produced them.
    """

    reference: np.ndarray
    target: np.ndarray
    source: str
