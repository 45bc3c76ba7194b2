"""Object region association between the reference and the target (section 3, eq 12).

Su et al. (2018), section 3: SIFT matches link the objects of the two images; two objects
linked by more than ``min_matches`` matches (paper: 2) are associated. An object with no
(or too few) matches is associated by template matching of its whole region. Section
4.2.2 then keeps as invariant points the matches whose disparity is within ``l`` (paper:
2 px) of the object's most frequent disparity D̄m (eq 12).

Matching (:func:`match_features`):

* each image is stretched to 8 bits between its 0.5th and 99.5th percentiles (valid
  pixels) for OpenCV's SIFT; keypoints are detected only on valid pixels at least
  ``border`` px away from invalid ones;
* for a rectified pair the candidates of a reference keypoint are the target keypoints
  within ``row_tolerance`` rows; the nearest one is kept if Lowe's ratio test passes
  (its distance < ``ratio`` x that of the nearest *other* target keypoint within
  ``ratio_rows`` rows) and the two are each other's nearest (mutual check). The ratio is
  taken over a band of rows rather than the whole image, so that repeated texture far
  away does not veto a correct match, and over more than the match's own rows, among
  whose few candidates any second-best looks far, so that the test still refuses
  ambiguous matches. Distances are computed band by band (``cv2.batchDistance`` with a
  row mask), not all against all;
* for an unrectified pair every target keypoint is a candidate (FLANN k-d trees, ratio
  test and mutual check), and a RANSAC fundamental matrix (1 px) removes the outliers.

Association (:func:`associate_objects`):

* a match belongs to the objects under its two (rounded) points;
* a reference object is associated with the target object that holds most of its matches
  if they are more than ``min_matches`` and more than ``min_matches`` of them agree with
  their D̄m (eq 12) (method ``"sift"``): the paper asks for more than 2 matches; counting
  only those that agree keeps a few scattered mismatches from setting D̄m far from the
  object's disparity;
* D̄m: the matches' disparities ``x_ref - x_tgt`` go into a 1 px histogram (bins centred
  on integers); the modal bin (the lowest one on ties) is refined by the median of the
  disparities that fall in it;
* invariant points: ``|D_k - D̄m| < invariant_threshold`` (eq 12);
* every other reference object is searched in the target by normalised cross-correlation
  of its masked bounding box (``cv2.matchTemplate``, ``TM_CCOEFF_NORMED`` with the object
  as mask) along the same rows (shifted by the matches' median vertical offset, +/- the
  row tolerance) and over the disparity range of the matches: the 3 px disparity bins
  holding more than ``min_matches`` matches and ``range_share`` of the fullest bin (so
  mismatches do not count), joined outwards from the fullest bin across gaps of at most
  ``search_margin`` (so a far cluster of repeated-texture mismatches does not count
  either), widened by ``search_margin``; +/- ``max_disparity`` without matches. Near the
  image's side edges the template keeps only the columns that stay inside the target
  over the whole range (when they hold half of the object). A range this narrow leaves
  fewer wrong offsets within reach of the template. The peak is refined to sub-pixel by a
  parabola; D̄m is that offset, ``tgt_id`` the target object covering the largest share
  of the shifted object if that share is at least ``template_min_overlap``, else 0
  (method ``"template"``). An object whose template is flat, does not fit the search
  strip, or scores below ``template_min_score`` stays unassociated (the paper associates
  every object; a template that barely correlates anywhere gives a wrong offset rather
  than none).

References
----------
Lowe, D. G. (2004). Distinctive image features from scale-invariant keypoints. IJCV 60(2).
Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, sections 3 and 4.2.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import scipy.ndimage

from radcons.errors import InputError
from radcons.numerics.modal import modal_disparity
from radcons.numerics.nearest import approximate_matcher
from radcons.numerics.stretch import stretch_for_detection
from radcons.numerics.subpixel import parabola_peak
from radcons.results import Association, Matches, ObjectAssociation
from radcons.stages.association.params import AssociationParams


def _image(image: np.ndarray, name: str) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 2:
        raise InputError(f"{name} must be a single-band 2-D image, got shape {image.shape}")
    if image.size == 0:
        raise InputError(f"{name} is empty")
    return image.astype(np.float32, copy=False)


def _detect(image: np.ndarray, params: AssociationParams) -> tuple[np.ndarray, np.ndarray]:
    u8, mask = stretch_for_detection(image, params.border)
    sift = cv2.SIFT_create(nfeatures=params.max_features, contrastThreshold=params.contrast_threshold)
    keypoints, descriptors = sift.detectAndCompute(u8, mask)
    if descriptors is None or not keypoints:
        return np.zeros((0, 2), np.float32), np.zeros((0, 128), np.float32)
    xy = np.array([kp.pt for kp in keypoints], np.float32)
    return xy, descriptors.astype(np.float32)


def _nearest_in_rows(
    query_xy: np.ndarray,
    query_desc: np.ndarray,
    train_xy: np.ndarray,
    train_desc: np.ndarray,
    tolerance: float,
    k: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest train descriptors of each query among those within ``tolerance`` rows.

    Queries are processed in bands of 16 rows against the train keypoints of the band's
    rows +/- ``tolerance`` (``cv2.batchDistance`` with a mask for the exact row test).

    Returns
    -------
    index : ndarray of int, shape (Q, k)
        Train indices, -1 where there are fewer than ``k`` candidates.
    squared : ndarray of float32, shape (Q, k)
        Squared L2 distances, inf where there is no candidate.
    """
    index = np.full((len(query_xy), k), -1, np.int64)
    squared = np.full((len(query_xy), k), np.inf, np.float32)
    band = 16.0
    order = np.argsort(train_xy[:, 1], kind="stable")
    train_y = train_xy[order, 1]
    for start in np.arange(0.0, float(query_xy[:, 1].max()) + band, band):
        rows = np.flatnonzero((query_xy[:, 1] >= start) & (query_xy[:, 1] < start + band))
        lo, hi = np.searchsorted(train_y, [start - tolerance, start + band + tolerance])
        if rows.size == 0 or hi == lo:
            continue
        cols = order[lo:hi]
        mask = (np.abs(query_xy[rows, 1][:, None] - train_xy[cols, 1][None, :]) <= tolerance).view(np.uint8)
        dist, nearest = cv2.batchDistance(
            query_desc[rows], train_desc[cols], cv2.CV_32F, normType=cv2.NORM_L2SQR, K=k, mask=mask
        )
        found = nearest >= 0
        width = nearest.shape[1]
        index[rows, :width] = np.where(found, cols[np.maximum(nearest, 0)], -1)
        squared[rows, :width] = np.where(found, dist, np.inf)
    return index, squared


def _match_rows(
    ref_xy: np.ndarray, ref_desc: np.ndarray, tgt_xy: np.ndarray, tgt_desc: np.ndarray, params: AssociationParams,
    queries: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Row-constrained best match, ratio test against the rows +/- ``ratio_rows``, mutual check.

    ``queries`` are the indices of the reference keypoints to match (default: all); the
    other reference keypoints only take part in the mutual check. Each query's result
    depends on the keypoints within ``max(ratio_rows, row_tolerance)`` rows of it (and,
    for the mutual check, ``2 * row_tolerance + 16``), so a scene is matched strip by strip.
    """
    index = np.arange(len(ref_xy)) if queries is None else np.asarray(queries, np.int64)
    if index.size == 0 or len(tgt_xy) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    forward, forward_d = _nearest_in_rows(ref_xy[index], ref_desc[index], tgt_xy, tgt_desc, params.row_tolerance, 1)
    best, best_d = forward[:, 0], forward_d[:, 0]
    wide, wide_d = _nearest_in_rows(
        ref_xy[index], ref_desc[index], tgt_xy, tgt_desc, max(params.ratio_rows, params.row_tolerance), 2
    )
    second_d = np.where(wide[:, 0] == best, wide_d[:, 1], wide_d[:, 0])
    ok = (best >= 0) & (np.sqrt(best_d) < params.ratio * np.sqrt(second_d))
    index, best = index[ok], best[ok]
    # the mutual check: the nearest reference keypoint of each target keypoint still chosen
    chosen = np.unique(best)
    if chosen.size == 0:
        return index, best
    backward, _ = _nearest_in_rows(tgt_xy[chosen], tgt_desc[chosen], ref_xy, ref_desc, params.row_tolerance, 1)
    nearest = np.full(len(tgt_xy), -1, np.int64)
    nearest[chosen] = backward[:, 0]
    mutual = nearest[best] == index
    return index[mutual], best[mutual]


def _match_all(
    ref_xy: np.ndarray, ref_desc: np.ndarray, tgt_xy: np.ndarray, tgt_desc: np.ndarray, params: AssociationParams
) -> tuple[np.ndarray, np.ndarray]:
    """Ratio test, mutual check and a RANSAC fundamental matrix, for unrectified pairs.

    Nearest neighbours come from FLANN's randomised k-d trees (approximate, as in Lowe
    2004; :func:`radcons.numerics.nearest.approximate_matcher`), which is much faster
    than brute force on thousands of descriptors.
    """
    matcher = approximate_matcher()
    forward = matcher.knnMatch(ref_desc, tgt_desc, k=2)
    backward = {m[0].queryIdx: m[0].trainIdx for m in matcher.knnMatch(tgt_desc, ref_desc, k=1) if m}
    pairs = [
        (m[0].queryIdx, m[0].trainIdx)
        for m in forward
        if m and (len(m) < 2 or m[0].distance < params.ratio * m[1].distance)
        and backward.get(m[0].trainIdx) == m[0].queryIdx
    ]
    if not pairs:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ref_idx, tgt_idx = (np.array(column, np.int64) for column in zip(*pairs))
    if ref_idx.size >= 8:
        _, inliers = cv2.findFundamentalMat(ref_xy[ref_idx], tgt_xy[tgt_idx], cv2.FM_RANSAC, 1.0, 0.999)
        if inliers is not None:
            keep = inliers.ravel().astype(bool)
            ref_idx, tgt_idx = ref_idx[keep], tgt_idx[keep]
    return ref_idx, tgt_idx


def match_features(
    reference: np.ndarray,
    target: np.ndarray,
    params: AssociationParams = AssociationParams(),
    rectified: bool = True,
) -> Matches:
    """SIFT matches between the reference and the target.

    Parameters
    ----------
    reference, target : ndarray
        Single-band images on any range, NaN where invalid.
    params : AssociationParams
    rectified : bool
        True for an epipolar-rectified pair (matches along the same rows).

    Returns
    -------
    Matches
        May be empty (e.g. a textureless image).

    Raises
    ------
    InputError
        An image is not 2-D or is empty.
    """
    reference = _image(reference, "reference")
    target = _image(target, "target")
    ref_xy, ref_desc = _detect(reference, params)
    tgt_xy, tgt_desc = _detect(target, params)
    if len(ref_xy) == 0 or len(tgt_xy) == 0:
        return Matches.empty()
    pick = _match_rows if rectified else _match_all
    ref_idx, tgt_idx = pick(ref_xy, ref_desc, tgt_xy, tgt_desc, params)
    return Matches(ref_xy[ref_idx].copy(), tgt_xy[tgt_idx].copy())


def _labels(labels: np.ndarray, image: np.ndarray, name: str) -> np.ndarray:
    labels = np.asarray(labels)
    if labels.shape != image.shape:
        raise InputError(f"{name} labels {labels.shape} differ in shape from their image {image.shape}")
    if labels.dtype.kind not in "iub":
        raise InputError(f"{name} labels must be integers, got {labels.dtype}")
    if labels.size and labels.min() < 0:
        raise InputError(f"{name} labels must be >= 0 (0 = background)")
    return labels.astype(np.int32, copy=False)


def _label_at(labels: np.ndarray, xy: np.ndarray) -> np.ndarray:
    cols = np.clip(np.rint(xy[:, 0]).astype(np.int64), 0, labels.shape[1] - 1)
    rows = np.clip(np.rint(xy[:, 1]).astype(np.int64), 0, labels.shape[0] - 1)
    return labels[rows, cols]


@dataclass(frozen=True)
class _Search:
    """Where the template search looks: vertical offset and disparity range."""

    dy: int
    dy_range: int
    d_low: int
    d_high: int


def _disparity_range(disparity: np.ndarray, support: int, share: float, gap: int) -> tuple[float, float]:
    """Range of the disparities that several matches share.

    A 1 px histogram (bins centred on integers) summed over 3 neighbouring bins; a bin is
    supported when it holds at least ``support`` matches and ``share`` of the fullest bin.
    The range grows from the fullest bin to the supported bins on either side as long as
    no more than ``gap`` bins separate them, so that scattered mismatches, and the small
    clusters that repeated texture makes far from the scene's disparities, do not widen
    it. With no supported bin (very few matches), the range of all the matches.
    """
    bins = np.rint(disparity).astype(np.int64)
    low = int(bins.min())
    counts = np.convolve(np.bincount(bins - low), np.ones(3, np.int64), mode="same")
    supported = np.flatnonzero(counts >= max(support, share * counts.max()))
    if supported.size == 0:  # too few matches for any bin to count: take them all
        return float(disparity.min()), float(disparity.max())
    peak = int(np.argmax(counts))
    first = last = peak
    for index in supported[supported > peak]:
        if index - last > gap:
            break
        last = index
    for index in supported[supported < peak][::-1]:
        if first - index > gap:
            break
        first = index
    return float(first + low), float(last + low)


def _search_window(matches: Matches, params: AssociationParams) -> _Search:
    dy_range = int(np.floor(params.row_tolerance))
    if len(matches) == 0:
        limit = int(np.ceil(params.max_disparity))
        return _Search(0, dy_range, -limit, limit)
    dy = int(np.rint(np.median(matches.tgt_xy[:, 1] - matches.ref_xy[:, 1])))
    low, high = _disparity_range(
        matches.disparity, params.min_matches + 1, params.range_share, int(params.search_margin)
    )
    return _Search(
        dy,
        dy_range,
        int(np.floor(low - params.search_margin)),
        int(np.ceil(high + params.search_margin)),
    )


def _template(
    ref_filled: np.ndarray,
    ref_valid: np.ndarray,
    tgt_filled: np.ndarray,
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    ref_id: int,
    box: tuple[slice, slice],
    search: _Search,
    params: AssociationParams,
) -> tuple[int, float, float] | None:
    """Template-match one reference object; ``(tgt_id, disparity, score)`` or None.

    The template keeps the object's columns that stay inside the target at every
    disparity of the search range, if they hold at least half of the object: near the
    image's side edges the rest of the object may lie outside the target, and a template
    that does not fit there is matched elsewhere. Otherwise the whole object is searched
    over the part of the range where it fits.
    """
    rows, cols = box
    height, width = tgt_filled.shape
    y0, y1 = rows.start, rows.stop
    whole = (labels_ref[rows, cols] == ref_id) & ref_valid[rows, cols]
    x0, x1 = max(cols.start, search.d_high), min(cols.stop, width + search.d_low)
    inside = whole[:, x0 - cols.start : x1 - cols.start] if x1 > x0 else whole[:, :0]
    if 2 * inside.sum() < whole.sum():  # too little stays inside: the whole object, where it fits
        x0, x1 = cols.start, cols.stop
        inside = whole
    mask = inside.astype(np.uint8)
    template = ref_filled[rows, x0:x1]
    # A template one column wide holds no horizontal structure to match (and OpenCV's
    # Python binding reads a 4 x 1 mask as a scalar).
    if template.shape[1] < 2 or mask.sum() < 2 or np.ptp(template[inside]) == 0:
        return None
    top = max(y0 + search.dy - search.dy_range, 0)
    bottom = min(y1 + search.dy + search.dy_range, height)
    left, right = max(x0 - search.d_high, 0), min(x1 - search.d_low, width)
    if bottom - top < y1 - y0 or right - left < x1 - x0:
        return None
    strip = tgt_filled[top:bottom, left:right]
    scores = cv2.matchTemplate(strip, template, cv2.TM_CCOEFF_NORMED, mask=mask)
    scores[~np.isfinite(scores) | (scores > 1.0 + 1e-3)] = -np.inf
    peak = np.unravel_index(int(np.argmax(scores)), scores.shape)
    score = float(scores[peak])
    if not score >= params.template_min_score:
        return None
    row, col = int(peak[0]), int(peak[1])
    sub = 0.0
    if 0 < col < scores.shape[1] - 1:
        sub = parabola_peak(scores[row, col - 1], score, scores[row, col + 1])
    tgt_x0, tgt_y0 = left + col, top + row
    disparity = float(x0 - (tgt_x0 + sub))
    under = labels_tgt[tgt_y0 : tgt_y0 + (y1 - y0), tgt_x0 : tgt_x0 + (x1 - x0)][mask.astype(bool)]
    under = under[under > 0]
    tgt_id = 0
    if under.size:
        ids, counts = np.unique(under, return_counts=True)
        if counts.max() >= params.template_min_overlap * mask.sum():
            tgt_id = int(ids[np.argmax(counts)])
    return tgt_id, disparity, score


def _invariant(indices: np.ndarray, disparity: np.ndarray, modal: float, threshold: float) -> np.ndarray:
    return indices[np.abs(disparity[indices] - modal) < threshold]


def associate_objects(
    reference: np.ndarray,
    target: np.ndarray,
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    matches: Matches,
    params: AssociationParams = AssociationParams(),
) -> Association:
    """Associate every reference object with a target object (section 3, eq 12).

    Parameters
    ----------
    reference, target : ndarray
        The images (NaN where invalid), used for template matching.
    labels_ref, labels_tgt : ndarray of int
        Object labels of each image, 0 = background.
    matches : Matches
        From :func:`match_features`.
    params : AssociationParams

    Returns
    -------
    Association
        One :class:`ObjectAssociation` per reference object that could be associated, in
        increasing ``ref_id``; the others in ``unassociated_ref``.

    Raises
    ------
    InputError
        Labels whose shape differs from their image, or non-integer labels.
    """
    reference = _image(reference, "reference")
    target = _image(target, "target")
    labels_ref = _labels(labels_ref, reference, "reference")
    labels_tgt = _labels(labels_tgt, target, "target")
    boxes = {i + 1: box for i, box in enumerate(scipy.ndimage.find_objects(labels_ref)) if box is not None}
    if not boxes:
        return Association(matches, (), ())
    disparity = matches.disparity.astype(np.float64)
    lab_r = _label_at(labels_ref, matches.ref_xy) if len(matches) else np.zeros(0, np.int32)
    lab_t = _label_at(labels_tgt, matches.tgt_xy) if len(matches) else np.zeros(0, np.int32)
    order = np.argsort(lab_r, kind="stable")
    starts = np.searchsorted(lab_r[order], list(boxes), side="left")
    stops = np.searchsorted(lab_r[order], list(boxes), side="right")
    search = _search_window(matches, params)
    ref_valid = np.isfinite(reference)
    ref_filled = np.where(ref_valid, reference, np.float32(0.0))
    tgt_valid = np.isfinite(target)
    tgt_mean = np.float32(target[tgt_valid].mean()) if tgt_valid.any() else np.float32(0.0)
    tgt_filled = np.where(tgt_valid, target, tgt_mean)
    objects: list[ObjectAssociation] = []
    unassociated: list[int] = []
    for (ref_id, box), start, stop in zip(boxes.items(), starts, stops):
        inside = order[start:stop]
        linked = inside[lab_t[inside] > 0]
        if linked.size:
            ids, counts = np.unique(lab_t[linked], return_counts=True)
            tgt_id, count = int(ids[np.argmax(counts)]), int(counts.max())
            if count > params.min_matches:
                link = np.sort(linked[lab_t[linked] == tgt_id])
                modal = modal_disparity(disparity[link])
                invariant = _invariant(link, disparity, modal, params.invariant_threshold)
                if invariant.size > params.min_matches:
                    objects.append(ObjectAssociation(ref_id, tgt_id, "sift", modal, link, invariant))
                    continue
        found = _template(
            ref_filled, ref_valid, tgt_filled, labels_ref, labels_tgt, ref_id, box, search, params
        )
        if found is None:
            unassociated.append(ref_id)
            continue
        tgt_id, modal, score = found
        link = np.sort(inside[lab_t[inside] == tgt_id]) if tgt_id > 0 else np.zeros(0, np.int64)
        invariant = _invariant(link, disparity, modal, params.invariant_threshold)
        objects.append(ObjectAssociation(ref_id, tgt_id, "template", modal, link, invariant, score))
    return Association(matches, tuple(objects), tuple(unassociated))
