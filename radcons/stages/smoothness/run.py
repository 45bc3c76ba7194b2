"""Smoothness consistency of a stereo pair by union group sparse denoising (section 5).

Su et al. (2018), section 5: two images from different sensors have different noise
levels, which hurts dense matching. Both are denoised together with the *union* group
sparse model, so that the same singular value thresholds bring them to one smoothness
level:

* **Group sparse model** (eq 13-16): for each reference patch of ``patch_size`` pixels
  square, its ``n_similar`` most similar patches (block matching) and itself form a group
  matrix; the group's singular values are soft-thresholded and the overlapping patch
  estimates averaged (eq 13). The group is centred on its mean patch first, as in SAIST.
* **Union groups** (section 5.2): inside each associated object a reference patch of the
  reference image and its partner in the target at the object's modal disparity D̄m
  (``x_target = x_reference - D̄m``); similar patches are searched only inside the matched
  object region of each image. The union group ``[G1; G2]`` gives the thresholds
  ``sigma_i = sqrt(max(lambda_i^2 / m - sigma_w^2, 0))`` (eq 17, ``m`` the union's number of
  patches) and ``tau_i = c sigma_w^2 / sigma_i``, and the same ``tau`` thresholds each
  image's own group.
* **Iterations** (eq 18-19): iterative regularisation ``y(k+1) = x(k) + delta (y - x(k))``
  and ``sigma_w(k) = gamma sqrt(max(sigma_0^2 - mean((y(k+1) - y)^2), 0))`` (SAIST,
  Dong, Shi and Li 2013), ``sigma_w(0) = sigma_0``.

Choices where the paper is silent (exposed in :class:`SmoothnessParams`):

* ``sigma_0`` of the union is the noise of the *noisier* image (``union_sigma="max"``),
  and eq 18 follows that image: the thresholds are the ones that denoise the noisier
  image, and the cleaner one receives the same, so it is smoothed to the same level
  instead of keeping its finer noise. ``"rms"`` takes the root mean square of the two
  sigmas and the union's mean squared change instead. Initial sigmas are the robust
  wavelet estimate of :func:`radcons.noise.noise_sigma` unless given.
* Outside the associated objects (background, roads, unassociated objects) union groups
  pair each reference patch with the target patch at the pair's background disparity,
  ``background_disparity`` or, when None, the median D̄m of the associated objects (0
  without objects), and search similar patches in the background of each image.
* Every reference pixel lies in a reference patch of the regular grid; target pixels that
  no partner patch covers (image borders, disocclusions between objects moved by
  different disparities) get union groups centred on the target's grid, with their
  reference partner at ``x + D``.
* Disparities are rounded to whole pixels; partners falling outside an image are clamped
  to its border. Similar patches come from a ``search_window`` square around each centre;
  patches of the group's region come first, other patches only fill up a region with too
  few. Block matching runs on the input, and again on the current estimate every
  ``rematch_every`` iterations (0: never).
* ``c`` is the paper's ``2 sqrt(2)``. The paper gives neither ``delta`` nor ``gamma``:
  ``delta`` is SAIST's 0.23; ``gamma`` is 1.0, not the 0.65 of SAIST's code, which pairs
  it with a larger constant (``2.8 sqrt(2) sqrt(2)`` = 5.6) in place of ``c``: with the
  paper's ``c``, 1.0 brings the model close to BM3D's denoising quality.
* ``step`` 8: one centre patch per 8 x 8 block; every pixel still gets about 30 estimates
  through the similar patches, in half the time of a denser grid. 5 iterations bring a
  mixed pair close to one noise level. (The measurements behind ``gamma``, ``step`` and
  ``iterations``: ``docs/tuning.md``.)
* Eq 19 feeds part of each image's removed noise back. With one ``delta`` for both, the
  noisier image gets more noise back at every iteration and the two never reach one noise
  level. ``feedback="equal"`` (default) scales the noisier image's ``delta`` by
  ``sigma_clean / sigma_noisy`` so that both get the same noise level back;
  ``"same"`` uses ``delta`` for both, as the paper's eq 19 reads.
* "The number of the similar patches is 30" is read per image: each image's group holds
  its centre and 30 similar patches, the union 62 patches. (Reading it per union group,
  16 + 16 patches, is four times cheaper: :func:`preview_params` uses it for previews.)
* NaN (invalid) pixels are filled with their nearest valid value for processing and are
  NaN again on output; noise levels and eq 18 use valid pixels only.

For live tuning, :func:`smoothness_preview` runs the stage on a full-resolution window
(fast mode: :func:`preview_params`). The compiled kernels live in
:mod:`radcons.stages.smoothness.group_sparse` (estimates and passes),
:mod:`radcons.stages.smoothness.patch_matching` (block matching),
:mod:`radcons.stages.smoothness.group_sparse_linalg` (eigenvalues) and
:mod:`radcons.stages.smoothness.inverse_iteration` (eigenvectors).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.ndimage

from radcons.errors import InputError, ParamsError
from radcons.noise import noise_sigma
from radcons.results import Association, StageImages
from radcons.stages.smoothness.group_sparse import (
    band_starts,
    denoise_pass,
    union_denoise_pass,
)
from radcons.stages.smoothness.params import SmoothnessParams
from radcons.stages.smoothness.patch_matching import block_match
from radcons.validate import single_band_image

__all__ = [
    "SmoothnessParams",
    "smoothness_consistency",
    "smoothness_preview",
    "preview_params",
    "group_sparse_denoise",
]


# ------------------------------------------------------------------------------ inputs


def _image(image: np.ndarray, name: str, patch: int) -> tuple[np.ndarray, np.ndarray]:
    """float32 copy with NaN filled by the nearest valid pixel, and the valid mask."""
    image = single_band_image(image, name, patch, f"is smaller than one {patch}x{patch} patch").copy()
    valid = np.isfinite(image)
    if not valid.all():
        nearest = scipy.ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        image = image[tuple(nearest)]
    return np.ascontiguousarray(image), valid


def _sigma(value: float, name: str) -> float:
    value = float(value)
    if not (value >= 0 and math.isfinite(value)):
        raise ParamsError(f"noise sigma of the {name} must be finite and >= 0, got {value}")
    return value


def _grid(length: int, patch: int, step: int) -> np.ndarray:
    """Patch corners every ``step`` px, the last one flush with the border."""
    corners = np.arange(0, length - patch + 1, step)
    if corners[-1] != length - patch:
        corners = np.append(corners, length - patch)
    return corners.astype(np.int32)


def _grid_points(shape: tuple[int, int], patch: int, step: int) -> tuple[np.ndarray, np.ndarray]:
    ys, xs = np.meshgrid(_grid(shape[0], patch, step), _grid(shape[1], patch, step), indexing="ij")
    return ys.ravel(), xs.ravel()


def _mean_sq(a: np.ndarray, b: np.ndarray, valid: np.ndarray) -> float:
    diff = (a - b)[valid].astype(np.float64)
    return float(np.mean(diff * diff))


# ------------------------------------------------------------------- single-image model


def group_sparse_denoise(image: np.ndarray, sigma: float, params: SmoothnessParams = SmoothnessParams()) -> np.ndarray:
    """Denoise one image with the group sparse model and its iterations (eq 13-19).

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Single-band image on its original range, NaN where invalid.
    sigma : float
        Standard deviation of its noise (``sigma_0`` of eq 18), in the image's units.
    params : SmoothnessParams

    Returns
    -------
    ndarray, shape (M, N), float32
        The estimate, NaN where the input was.

    Raises
    ------
    InputError
        Not 2-D, smaller than a patch, or all NaN.
    ParamsError
        Negative or non-finite ``sigma``.

    References
    ----------
    Dong, W., Shi, G., Li, X. (2013). Nonlocal image restoration with bilateral variance
    estimation: a low-rank approach. IEEE Trans. Image Process. 22(2), 700-711.
    """
    patch = params.patch_size
    noisy, valid = _image(image, "image", patch)
    sigma0 = _sigma(sigma, "image")
    centres_y, centres_x = _grid_points(noisy.shape, patch, params.step)
    regions = np.zeros(noisy.shape, np.int32)
    group_regions = np.zeros(centres_y.size, np.int32)
    radius = params.search_window // 2
    m = params.n_similar + 1
    starts = band_starts(centres_y, 2 * radius + patch)
    estimate = noisy
    for k in range(params.iterations):
        current = noisy if k == 0 else estimate + np.float32(params.delta) * (noisy - estimate)
        sigma_w = sigma0 if k == 0 else params.gamma * math.sqrt(max(sigma0**2 - _mean_sq(current, noisy, valid), 0.0))
        if k == 0 or (params.rematch_every and k % params.rematch_every == 0):
            ys, xs = block_match(current, centres_y, centres_x, regions, group_regions, patch, radius, m)
        estimate = denoise_pass(current, ys, xs, patch, sigma_w, params.c, starts)
    estimate[~valid] = np.nan
    return estimate


# --------------------------------------------------------------------------- union model


def _region_maps(
    labels_ref: np.ndarray, labels_tgt: np.ndarray, association: Association, shape: tuple[int, int],
    background_disparity: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Region of every pixel (0 background, ``k + 1`` association ``k``) and its disparity."""
    regions = []
    for labels, name in ((labels_ref, "labels_ref"), (labels_tgt, "labels_tgt")):
        labels = np.asarray(labels)
        if labels.shape != shape:
            raise InputError(f"{name} has shape {labels.shape}, the images {shape}")
        if labels.dtype.kind not in "iub":
            raise InputError(f"{name} must hold integer object ids, got dtype {labels.dtype}")
        if labels.size and labels.min() < 0:
            raise InputError(f"{name} holds negative object ids")
        regions.append(labels.astype(np.int64))
    if not isinstance(association, Association):
        raise InputError(f"association must be a radcons.results.Association, got {type(association).__name__}")
    objects = association.objects
    modal = np.array([obj.modal_disparity for obj in objects], np.float64)
    if not np.all(np.isfinite(modal)):
        raise InputError("an associated object has a non-finite modal disparity")
    if background_disparity is None:
        background_disparity = float(np.median(modal)) if modal.size else 0.0
    disparities = np.rint(np.concatenate([[background_disparity], modal])).astype(np.int32)
    maps = []
    for labels, key in zip(regions, ("ref_id", "tgt_id")):
        lut = np.zeros(int(labels.max(initial=0)) + 1, np.int32)
        for k, obj in enumerate(objects):
            label = getattr(obj, key)
            if 0 < label < lut.size:
                lut[label] = k + 1
        maps.append(np.ascontiguousarray(lut[labels]))
    return maps[0], maps[1], disparities


def _box_any(marks: np.ndarray, patch: int) -> np.ndarray:
    """``out[y, x]`` = True where a mark lies in ``[y - patch + 1, y] x [x - patch + 1, x]``."""
    counts = np.cumsum(np.cumsum(marks.astype(np.int32), axis=0), axis=1)
    padded = np.pad(counts, ((patch, 0), (patch, 0)))
    window = padded[patch:, patch:] - padded[:-patch, patch:] - padded[patch:, :-patch] + padded[:-patch, :-patch]
    return window > 0


def _union_centres(
    regions_ref: np.ndarray, regions_tgt: np.ndarray, disparities: np.ndarray, patch: int, step: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Centre patches of the union groups: the reference grid with its partners, then the
    target grid positions that no partner covers, with theirs (section 5.2 rule a)."""
    height, width = regions_ref.shape
    half = patch // 2
    y1, x1 = _grid_points((height, width), patch, step)
    region1 = regions_ref[y1 + half, x1 + half]
    x2 = np.clip(x1 - disparities[region1], 0, width - patch).astype(np.int32)
    starts = np.zeros((height, width), bool)
    starts[y1, x2] = True
    covered = _box_any(starts, patch)
    ty, tx = _grid_points((height, width), patch, step)
    uncovered = _box_any(~covered, patch)[ty + patch - 1, tx + patch - 1]
    ty, tx = ty[uncovered], tx[uncovered]
    region2 = regions_tgt[ty + half, tx + half]
    tx_ref = np.clip(tx + disparities[region2], 0, width - patch).astype(np.int32)
    ys_ref = np.concatenate([y1, ty])
    order = np.argsort(ys_ref, kind="stable")  # by row, for the parallel bands
    ys_ref = ys_ref[order].astype(np.int32)
    xs_ref = np.concatenate([x1, tx_ref])[order].astype(np.int32)
    xs_tgt = np.concatenate([x2, tx])[order].astype(np.int32)
    group_regions = np.concatenate([region1, region2])[order].astype(np.int32)
    return ys_ref, xs_ref, ys_ref.copy(), xs_tgt, group_regions, int(ty.size)


def _pair_sigmas(reference: np.ndarray, target: np.ndarray, sigma: tuple[float, float] | None) -> tuple[float, float]:
    """Noise sigma of each image: the given ones, checked, or Donoho's estimates."""
    if sigma is None:
        return (noise_sigma(reference), noise_sigma(target))
    if np.shape(sigma) != (2,):
        raise ParamsError(f"sigma must be (reference, target), got {sigma!r}")
    return (_sigma(sigma[0], "reference"), _sigma(sigma[1], "target"))


def _union_noise(sigmas: tuple[float, float], params: SmoothnessParams) -> tuple[int, float, list[float]]:
    """The noisier image (0 or 1), the union's ``sigma_0`` (eq 18) and each image's eq 19 weight."""
    noisier = int(sigmas[1] > sigmas[0])
    if params.union_sigma == "max":
        sigma0 = sigmas[noisier]
    else:
        sigma0 = math.sqrt(0.5 * (sigmas[0] ** 2 + sigmas[1] ** 2))
    feedback = [params.delta, params.delta]
    if params.feedback == "equal" and min(sigmas) > 0:
        feedback[noisier] = params.delta * sigmas[1 - noisier] / sigmas[noisier]
    return noisier, sigma0, feedback


def _union_iterations(
    noisy: tuple[np.ndarray, np.ndarray],
    valid: tuple[np.ndarray, np.ndarray],
    regions: tuple[np.ndarray, np.ndarray],
    centres: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    params: SmoothnessParams,
    noise: tuple[int, float, list[float]],
) -> tuple[tuple[np.ndarray, np.ndarray], list[float]]:
    """The iterations of eq 17-19 on the union groups; the two estimates and ``sigma_w`` of each.

    ``centres`` are the groups' centre patches ``(ys_ref, xs_ref, ys_tgt, xs_tgt,
    group_regions)`` (:func:`_union_centres`); ``noise`` is :func:`_union_noise`'s.
    """
    patch = params.patch_size
    ys_ref, xs_ref, ys_tgt, xs_tgt, group_regions = centres
    noisier, sigma0, feedback = noise
    radius = params.search_window // 2
    m = params.n_similar + 1
    starts = band_starts(ys_ref, 2 * radius + patch)
    estimates = noisy
    schedule = []
    for k in range(params.iterations):
        if k == 0:
            current = noisy
            sigma_w = sigma0
        else:
            current = tuple(x + np.float32(d) * (y - x) for x, y, d in zip(estimates, noisy, feedback))
            change = [_mean_sq(current[i], noisy[i], valid[i]) for i in range(2)]
            change_sq = change[noisier] if params.union_sigma == "max" else 0.5 * (change[0] + change[1])
            sigma_w = params.gamma * math.sqrt(max(sigma0**2 - change_sq, 0.0))
        if k == 0 or (params.rematch_every and k % params.rematch_every == 0):
            groups_ref = block_match(current[0], ys_ref, xs_ref, regions[0], group_regions, patch, radius, m)
            groups_tgt = block_match(current[1], ys_tgt, xs_tgt, regions[1], group_regions, patch, radius, m)
        estimates = union_denoise_pass(
            current[0], current[1], *groups_ref, *groups_tgt, patch, sigma_w, params.c, starts
        )
        schedule.append(sigma_w)
    return estimates, schedule


def smoothness_consistency(
    reference: np.ndarray,
    target: np.ndarray,
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    association: Association,
    params: SmoothnessParams = SmoothnessParams(),
    sigma: tuple[float, float] | None = None,
) -> StageImages:
    """Bring both images of a pair to one smoothness level (Su et al. 2018, section 5).

    Union group sparse denoising (eq 13-19) of the reference and the target together; see
    the module docstring for the model and the choices made where the paper is silent.

    Parameters
    ----------
    reference, target : ndarray, shape (M, N)
        The pair's images on their original range (float32 or any real dtype), NaN where
        invalid; epipolar-rectified, same shape.
    labels_ref, labels_tgt : ndarray of int, shape (M, N)
        Object labels of each image, 0 = background.
    association : Association
        Object pairs and their modal disparities D̄m (section 3).
    params : SmoothnessParams
    sigma : (float, float) or None
        Noise sigma of the reference and the target; None estimates them.

    Returns
    -------
    StageImages
        ``reference``, ``target`` (float32, NaN where the inputs were) and ``info`` with
        ``sigma_initial`` and ``sigma_final`` (estimated noise sigma of each image before
        and after), ``noise_ratio_initial`` and ``noise_ratio_final`` (larger over
        smaller), ``sigma_w`` (the union noise level of each iteration), ``feedback``
        (eq 19 weight of the reference and the target), ``iterations``,
        ``n_groups``, ``n_target_groups`` (groups added to cover the target),
        ``background_disparity`` and ``object_disparities`` (the rounded D̄m used).

    Raises
    ------
    InputError
        Images or labels of the wrong shape or type, an image smaller than a patch or all
        NaN, a malformed association.
    ParamsError
        A negative or non-finite sigma.
    """
    patch = params.patch_size
    noisy_ref, valid_ref = _image(reference, "reference", patch)
    noisy_tgt, valid_tgt = _image(target, "target", patch)
    if noisy_ref.shape != noisy_tgt.shape:
        raise InputError(
            f"reference is {noisy_ref.shape} but target is {noisy_tgt.shape}; a rectified pair needs equal sizes"
        )
    regions_ref, regions_tgt, disparities = _region_maps(
        labels_ref, labels_tgt, association, noisy_ref.shape, params.background_disparity
    )
    sigmas = _pair_sigmas(reference, target, sigma)
    *centres, extra = _union_centres(regions_ref, regions_tgt, disparities, patch, params.step)
    noise = _union_noise(sigmas, params)
    (out_ref, out_tgt), schedule = _union_iterations(
        (noisy_ref, noisy_tgt), (valid_ref, valid_tgt), (regions_ref, regions_tgt), tuple(centres), params, noise
    )
    out_ref[~valid_ref] = np.nan
    out_tgt[~valid_tgt] = np.nan
    final = (noise_sigma(out_ref), noise_sigma(out_tgt))
    feedback = noise[2]
    info = {
        "sigma_initial": sigmas,
        "sigma_final": final,
        "noise_ratio_initial": _ratio(*sigmas),
        "noise_ratio_final": _ratio(*final),
        "sigma_w": tuple(schedule),
        "feedback": (float(feedback[0]), float(feedback[1])),
        "iterations": params.iterations,
        "n_groups": int(centres[0].size),
        "n_target_groups": extra,
        "background_disparity": int(disparities[0]),
        "object_disparities": tuple(int(d) for d in disparities[1:]),
    }
    return StageImages(out_ref, out_tgt, info)


def _ratio(a: float, b: float) -> float:
    low, high = sorted((a, b))
    if high == 0.0:
        return 1.0
    return high / low if low > 0.0 else math.inf


def preview_params(params: SmoothnessParams) -> SmoothnessParams:
    """The lighter parameters :func:`smoothness_preview` uses in its fast mode.

    Half the similar patches per image group (so union groups of ``n_similar + 2``
    patches, the other reading of the paper's "30 similar patches") and a search window
    of at most 15 px: about four times less work, for a result close to the full stage's
    (``benchmarks/bench_smoothness.py`` measures how close).
    """
    window = min(params.search_window, 15)
    return replace(params, n_similar=max(1, min(params.n_similar // 2, window**2 - 1)), search_window=window)


def smoothness_preview(
    reference: np.ndarray,
    target: np.ndarray,
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    association: Association,
    window: tuple[int, int, int, int] | None = None,
    params: SmoothnessParams = SmoothnessParams(),
    sigma: tuple[float, float] | None = None,
    size: int = 512,
    fast: bool = True,
) -> StageImages:
    """Run the stage on one window of the pair, for live tuning.

    The same window ``(x0, y0, x1, y1)`` (end exclusive) is cut from both images and both
    label rasters, at full resolution so that the noise is the one the full run sees;
    object disparities are unchanged (rows and columns shift together). The noise sigmas
    are estimated on the whole images when not given, so the preview uses the thresholds
    the full run would. Without ``window``, the central ``size x size`` window. With
    ``fast`` (default) the stage runs with :func:`preview_params`, otherwise with
    ``params`` unchanged (about four times the work).

    Returns
    -------
    StageImages
        The window of each image after the stage; ``info`` as for the full stage plus
        ``window`` and ``params`` (the parameters the preview ran with).
    """
    reference = np.asarray(reference)
    height, width = reference.shape[:2]
    if window is None:
        h, w = min(size, height), min(size, width)
        y0, x0 = (height - h) // 2, (width - w) // 2
        window = (x0, y0, x0 + w, y0 + h)
    x0, y0, x1, y1 = (int(v) for v in window)
    if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
        raise ParamsError(f"preview window {window} is not inside the {width}x{height} image")
    if sigma is None:
        sigma = (noise_sigma(reference), noise_sigma(target))
    run_params = preview_params(params) if fast else params
    cut = (slice(y0, y1), slice(x0, x1))
    result = smoothness_consistency(
        reference[cut], np.asarray(target)[cut], np.asarray(labels_ref)[cut], np.asarray(labels_tgt)[cut],
        association, run_params, sigma,
    )
    info = {**result.info, "window": (x0, y0, x1, y1), "params": run_params}
    return StageImages(result.reference, result.target, info)
