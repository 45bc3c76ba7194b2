"""Deciding whether a pair is epipolar-rectified when nobody said so.

Two images of different sizes cannot be a rectified pair (:func:`radcons.io.load_pair_files`
takes them as unrectified). Two of equal sizes usually are, but raw crops of a satellite
pair have the same size too; their rows do not correspond. The check: SIFT matches of the
two images (at most 1024 px on a side), and the median vertical offset of the matches. On a
rectified pair most matches lie on the same row, so the median is within a few pixels even
with many false matches; on a raw pair it is the pair's vertical parallax.

Measured (median ``|dy|``, px, Lowe ratio 0.7): rectified pairs US3D JAX_072 2.5 and
JAX_122 0.6 (multi-date WorldView-3), Pleiades Reunion 0.2, Middlebury Cones 0.1, demo
pairs 0.4-1.7; raw pairs Pleiades Kahramanmaras 2016/2016 51.8 and 2016/2023 62.6,
Ventoux 331. The threshold, 8 px, sits between the two groups with a margin on each side.
One raw pair falls below it: Kahramanmaras 2016 (``pre_event_img2``) / 2023
(``post_event_img2``), two views of nearly the same direction, 5.9 px. Its rows do not
correspond either: the plane of vertical offset fitted on its matches
(:func:`radcons.stages.rectify.row_levelling.measure_row_offset`, which levelling uses
too) reaches 10.5 px at a corner, where it stays within 2.6 px on every rectified pair
above; a pair whose plane goes beyond 8 px is taken as unrectified
(:attr:`~radcons.stages.rectify.row_levelling.RowOffset.unrectified`).

A rectified pair then has its target's rows levelled (:func:`level_rows`,
:mod:`radcons.stages.rectify.row_levelling`): the few pixels of vertical offset that a pair
delivered as rectified may keep (JAX_072: 2.5 px) are fitted on SIFT matches and taken out
of the target, unless they stay within half a pixel.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from radcons.io import Pair
from radcons.stages.rectify.params import UNRECTIFIED_PARALLAX_PX
from radcons.stages.rectify.row_levelling import RowOffset, level_target, measure_row_offset

__all__ = ["settle_geometry", "level_rows", "median_vertical_parallax", "UNRECTIFIED_PARALLAX_PX"]

_CHECK_SIDE = 1024


def median_vertical_parallax(reference: np.ndarray, target: np.ndarray) -> tuple[float, int]:
    """Median ``|y_ref - y_tgt|`` of SIFT matches, px of the full images, and the match count.

    Returns ``(nan, 0)`` when there are no matches.
    """
    from radcons.stages.rectify.run import RectifyParams, match_sift

    step = max(1, int(np.ceil(max(reference.shape + target.shape) / _CHECK_SIDE)))
    matches = match_sift(reference[::step, ::step], target[::step, ::step], RectifyParams(max_features=4000, ratio=0.7))
    if len(matches) == 0:
        return float("nan"), 0
    return float(np.median(np.abs(matches.ref_xy[:, 1] - matches.tgt_xy[:, 1])) * step), len(matches)


def settle_geometry(pair: Pair, level: bool = True) -> Pair:
    """Return the pair with ``rectified`` decided, and the reason in its metadata.

    Only a pair whose geometry was assumed (equal sizes, nothing said) is checked (the
    median vertical parallax of its matches, then the plane of its vertical offset; module
    notes); a pair whose geometry was given or follows from its sizes is returned with the
    reason noted.
    The reason goes to ``metadata["geometry"]`` (and so to the outputs and the summary).
    A rectified pair then has its target's rows levelled when ``level`` (:func:`level_rows`).
    """
    if pair.geometry == "given":
        return level_rows(pair) if level and pair.rectified else pair
    if pair.geometry == "sizes":
        note = f"unrectified: the images differ in size ({pair.reference.data.shape} vs {pair.target.data.shape})"
        return replace(pair, metadata={**pair.metadata, "geometry": note})
    parallax, count = median_vertical_parallax(pair.reference.as_float32(), pair.target.as_float32())
    unrectified = count > 0 and parallax > UNRECTIFIED_PARALLAX_PX
    note = (
        f"{'unrectified' if unrectified else 'rectified'}: median vertical parallax of {count} SIFT matches "
        f"{parallax:.1f} px (threshold {UNRECTIFIED_PARALLAX_PX:g} px)"
    )
    offset = None
    if not unrectified:
        offset = measure_row_offset(pair.reference.as_float32(), pair.target.as_float32())
        if offset.unrectified:
            unrectified = True
            note = (
                f"unrectified: median vertical parallax of {count} SIFT matches {parallax:.1f} px, but the plane of "
                f"vertical offset fitted on {offset.inliers} of {offset.matches} reaches {offset.largest:.1f} px over the image "
                f"(threshold {UNRECTIFIED_PARALLAX_PX:g} px)"
            )
    settled = replace(pair, rectified=not unrectified, geometry="given", metadata={**pair.metadata, "geometry": note})
    return level_rows(settled, offset) if level and settled.rectified else settled


def level_rows(pair: Pair, offset: RowOffset | None = None) -> Pair:
    """Return a rectified pair with the vertical offset of its target taken out.

    The offset is a plane fitted on SIFT matches (:func:`radcons.stages.rectify.row_levelling.
    measure_row_offset`). When its median at the matches exceeds half a pixel, and it stays
    within :data:`UNRECTIFIED_PARALLAX_PX` over the image (beyond, the rows do not correspond
    and levelling is not the cure; the rule is :attr:`~radcons.stages.rectify.row_levelling.
    RowOffset.applied`), the target and its object labels are resampled
    (:func:`radcons.stages.rectify.row_levelling.level_target`; bicubic, rounded back to the
    target's dtype; labels by nearest neighbour). The reference, the ground-truth disparity
    (reference frame) and the change mask are untouched. What was measured and done goes to
    ``metadata["rows"]`` (and so to the outputs and the summary). The target loses its
    green leaf index and keeps its georeferencing. ``offset``, when given, is that
    measurement already made on this pair (:func:`settle_geometry`).
    """
    from radcons.pipeline import to_output_dtype

    if offset is None:
        offset = measure_row_offset(pair.reference.as_float32(), pair.target.as_float32())
    note = offset.describe()
    if offset.applied:
        target = pair.target
        levelled = level_target(target.as_float32(), offset.plane, target.valid_mask())
        data = to_output_dtype(levelled, target.data.dtype, target.nodata)
        labels = pair.target_objects
        if labels is not None:
            labels = level_target(labels.astype(np.float32), offset.plane, nearest=True).astype(labels.dtype)
        return replace(
            pair,
            target=replace(target, data=data, greenness=None),
            target_objects=labels,
            metadata={**pair.metadata, "rows": note},
        )
    return replace(pair, metadata={**pair.metadata, "rows": note})
