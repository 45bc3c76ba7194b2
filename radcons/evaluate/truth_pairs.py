"""Real stereo pairs with ground-truth disparity, as :class:`radcons.io.Pair`.

Middlebury 2003 "Cones" (quarter size, from a data folder) and Middlebury 2014
"Motorcycle" (shipped with scikit-image) follow the project's convention
``left(x, y) <-> right(x - d, y)`` with positive d; this was checked by warping (the mean
absolute grey difference of the ground-truth correspondences is about 8 grey levels with
this sign and about 40 with the opposite one).

The US3D / DFC2019 Jacksonville tiles (:func:`load_us3d`, :func:`us3d_names`) are real
multi-date WorldView-3 pairs, epipolar-rectified, with a lidar-derived disparity of the
left image (``*_LEFT_DSP.tif``, -999 = none). Its sign is ours too: the SIFT matches of
the two images satisfy ``x_left - x_right = +d`` and not ``-d``
(``tests/test_truth_pairs.py`` checks it on both tiles). The lidar disparity is not
registered to a pixel, though: the signed median of ``x_left - x_right - d`` over the SIFT
matches is +0.9 px on JAX_072_011_022 and -2.1 px on JAX_122_019_005 (SGBM's median error
+1.2 and -1.9 px), so a 1 px tolerance counts most correct matches of JAX_122 as wrong for
every method; the 3 px tolerance is the one that compares methods there. The truth is
used as given (no shift). The rows are not registered either: JAX_072's SIFT matches lie
2.5 px lower in the left image than in the right, so the loader levels the target's rows
(:func:`radcons.geometry.level_rows`; census SGM within 3 px of the truth 0.33 -> 0.64,
SGBM 0.41 -> 0.61; JAX_122's 0.2 px is left alone).

Objects: neither pair has object labels, so objects are made from the ground truth, the
way the paper's buildings are regions of near-constant height: the disparity is cut into
layers ``layer_width`` px wide, each layer's 4-connected regions of at least ``min_area``
pixels become objects, numbered 1, 2, ... by decreasing area (at most ``max_objects``).
The target's labels are the reference's labels carried along the ground truth (a pixel
``(x, y)`` of object k lands on the two target pixels around ``(x - d, y)``; where several
land on one target pixel the nearest, largest d, wins), so the same id marks the same object in both images.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from skimage import measure

from radcons.errors import InputError, ParamsError
from radcons.geometry import level_rows
from radcons.io import Pair, Raster, read_raster

__all__ = [
    "load_cones",
    "load_motorcycle",
    "load_us3d",
    "us3d_names",
    "objects_from_disparity",
    "labels_to_target",
]

#: The value marking pixels without lidar disparity in the US3D ``*_LEFT_DSP.tif`` files.
US3D_NODATA = -999.0


def objects_from_disparity(
    disparity: np.ndarray, layer_width: float = 4.0, min_area: int = 300, max_objects: int = 12
) -> np.ndarray:
    """Object labels from a ground-truth disparity map (connected disparity layers).

    Parameters
    ----------
    disparity : ndarray
        Disparity, NaN where unknown (never part of an object).
    layer_width : float
        Width of the disparity layers in pixels.
    min_area : int
        Smallest object, in pixels.
    max_objects : int
        Largest number of objects kept (the largest ones).

    Returns
    -------
    ndarray of int32
        Labels, 0 = background, 1.. by decreasing area.
    """
    if not layer_width > 0 or min_area < 1 or max_objects < 1:
        raise ParamsError("layer_width, min_area and max_objects must be positive")
    known = np.isfinite(disparity)
    layer = np.full(disparity.shape, -1, np.int64)
    layer[known] = np.floor(disparity[known] / layer_width).astype(np.int64)
    components = measure.label(layer + 1, background=0, connectivity=1)
    ids, areas = np.unique(components[components > 0], return_counts=True)
    keep = ids[areas >= min_area]
    keep_areas = areas[areas >= min_area]
    order = keep[np.argsort(-keep_areas, kind="stable")][:max_objects]
    lookup = np.zeros(components.max() + 1, np.int32)
    lookup[order] = np.arange(1, order.size + 1, dtype=np.int32)
    return lookup[components]


def labels_to_target(labels: np.ndarray, disparity: np.ndarray) -> np.ndarray:
    """Carry reference labels into the target frame along the disparity (z-buffered).

    Parameters
    ----------
    labels : ndarray of int
        Reference labels (0 = background).
    disparity : ndarray
        Reference-frame disparity, ``reference(x, y) <-> target(x - d, y)``.

    Returns
    -------
    ndarray of int32
        Target labels; target pixels no labelled reference pixel lands on are 0.
    """
    if labels.shape != disparity.shape:
        raise InputError(f"labels {labels.shape} and disparity {disparity.shape} differ in shape")
    rows, cols = np.nonzero((labels > 0) & np.isfinite(disparity))
    d = disparity[rows, cols].astype(np.float64)
    x = cols - d
    # each pixel covers both target columns around x - d, so that no hole opens where a
    # surface is stretched in the target
    target_cols = np.concatenate([np.floor(x), np.ceil(x)]).astype(np.intp)
    rows, cols, d = np.tile(rows, 2), np.tile(cols, 2), np.tile(d, 2)
    inside = (target_cols >= 0) & (target_cols < labels.shape[1])
    rows, cols, target_cols, d = rows[inside], cols[inside], target_cols[inside], d[inside]
    order = np.argsort(d, kind="stable")  # nearest (largest d) written last, so it wins
    out = np.zeros(labels.shape, np.int32)
    out[rows[order], target_cols[order]] = labels[rows[order], cols[order]]
    return out


def _with_objects(pair: Pair, **object_params) -> Pair:
    pair.reference_objects = objects_from_disparity(pair.disparity, **object_params)
    pair.target_objects = labels_to_target(pair.reference_objects, pair.disparity)
    return pair


def load_cones(data_dir: str | Path, **object_params) -> Pair:
    """Middlebury 2003 "Cones" (quarter size, 450 x 375) with ground truth and objects.

    Parameters
    ----------
    data_dir : str or Path
        Folder holding ``left.tif``, ``right.tif`` and ``disp_left_gt.tif`` (float32
        disparity in px, 0 = unknown, which becomes NaN).
    **object_params
        Passed to :func:`objects_from_disparity` (``layer_width``, ``min_area``,
        ``max_objects``).

    Returns
    -------
    Pair
        uint8 images, float32 disparity (NaN = unknown), object labels in both frames.

    References
    ----------
    Scharstein, D., Szeliski, R. (2003). High-accuracy stereo depth maps using structured
    light. CVPR 2003.
    """
    folder = Path(data_dir)
    if not folder.is_dir():
        raise InputError("Cones data folder not found", folder)
    reference = read_raster(folder / "left.tif")
    target = read_raster(folder / "right.tif")
    disparity = read_raster(folder / "disp_left_gt.tif").data.astype(np.float32)
    if disparity.shape != reference.data.shape or target.data.shape != reference.data.shape:
        raise InputError("Cones images and ground truth differ in size", folder)
    disparity[disparity <= 0] = np.nan
    pair = Pair(
        reference, target, disparity=disparity, name="cones", source=folder,
        metadata={"origin": "Middlebury 2003 Cones, quarter size (Scharstein and Szeliski 2003)"},
    )
    return _with_objects(pair, **object_params)


def load_motorcycle(downsample: int = 2, **object_params) -> Pair:
    """Middlebury 2014 "Motorcycle" from ``skimage.data.stereo_motorcycle``, in grey.

    The colour images (741 x 500) are converted to grey (``rgb2gray``, scaled to 0..255)
    and reduced by block averaging over ``downsample x downsample`` blocks. The ground
    truth (infinite where unknown, which becomes NaN) is reduced with them: a block's
    disparity is the mean of its four values divided by ``downsample`` when all are known
    and span less than 1 px (full resolution), else NaN, so depth edges become unknown.

    Parameters
    ----------
    downsample : int
        Reduction factor (1 keeps the full size).
    **object_params
        Passed to :func:`objects_from_disparity`.

    Returns
    -------
    Pair
        float32 images on 0..255, float32 disparity, object labels in both frames.

    References
    ----------
    Scharstein, D. et al. (2014). High-resolution stereo datasets with subpixel-accurate
    ground truth. GCPR 2014.
    """
    from skimage import data
    from skimage.color import rgb2gray

    if downsample < 1:
        raise ParamsError(f"downsample must be >= 1, got {downsample}")
    left, right, disparity = data.stereo_motorcycle()
    disparity = np.where(np.isfinite(disparity), disparity, np.nan).astype(np.float64)
    rows = (left.shape[0] // downsample) * downsample
    cols = (left.shape[1] // downsample) * downsample

    def blocks(array: np.ndarray) -> np.ndarray:
        array = array[:rows, :cols]
        return array.reshape(rows // downsample, downsample, cols // downsample, downsample)

    grey = [blocks(rgb2gray(image) * 255.0).mean(axis=(1, 3)) for image in (left, right)]
    block_disp = blocks(disparity)
    spread = block_disp.max(axis=(1, 3)) - block_disp.min(axis=(1, 3))  # NaN if any unknown
    reduced = np.where(spread < 1.0, block_disp.mean(axis=(1, 3)) / downsample, np.nan)
    pair = Pair(
        Raster(grey[0].astype(np.float32)),
        Raster(grey[1].astype(np.float32)),
        disparity=reduced.astype(np.float32),
        name="motorcycle",
        metadata={"origin": "Middlebury 2014 Motorcycle via skimage.data (Scharstein et al. 2014)"},
    )
    return _with_objects(pair, **object_params)


def us3d_names(data_dir: str | Path) -> list[str]:
    """The US3D tiles of a folder: the ``NAME`` of every ``NAME_LEFT_DSP.tif``, sorted.

    Raises
    ------
    InputError
        The folder is missing or holds no tile.
    """
    folder = Path(data_dir)
    if not folder.is_dir():
        raise InputError("US3D data folder not found", folder)
    names = sorted(p.name[: -len("_LEFT_DSP.tif")] for p in folder.glob("*_LEFT_DSP.tif"))
    if not names:
        raise InputError("no *_LEFT_DSP.tif tile in the US3D folder", folder)
    return names


def load_us3d(
    data_dir: str | Path, name: str, crop: int | None = None, level: bool = True, **object_params
) -> Pair:
    """One US3D / DFC2019 tile: a multi-date WorldView-3 epipolar pair with lidar disparity.

    Parameters
    ----------
    data_dir : str or Path
        Folder holding ``{name}_LEFT_RGB.tif``, ``{name}_RIGHT_RGB.tif`` (uint8 RGB, read
        as BT.601 luminance, see :mod:`radcons.io.bands`) and ``{name}_LEFT_DSP.tif``
        (float32 disparity of the left image, -999 = none, which becomes NaN).
    name : str
        The tile, e.g. ``"JAX_072_011_022"`` (see :func:`us3d_names`).
    crop : int, optional
        Keep only the central ``crop x crop`` window (quicker benchmarks).
    level : bool
        Take the target's vertical offset out (:func:`radcons.geometry.level_rows`, on the
        whole tile, before the crop): JAX_072 keeps 2.5 px of it, which costs dense
        matching half its correct matches. False gives the tile as published.
    **object_params
        Passed to :func:`objects_from_disparity`; defaults here ``layer_width=3``,
        ``min_area=1500`` (buildings and ground layers of a 0.3 m tile).

    Returns
    -------
    Pair
        uint8 grey images, float32 disparity (NaN = none), object labels in both frames.

    Raises
    ------
    InputError
        A file missing, or the three rasters differ in size.

    References
    ----------
    Bosch, M. et al. (2019). Semantic stereo for incidental satellite images. WACV 2019.
    """
    folder = Path(data_dir)
    paths = [folder / f"{name}_{part}.tif" for part in ("LEFT_RGB", "RIGHT_RGB", "LEFT_DSP")]
    for path in paths:
        if not path.is_file():
            raise InputError("US3D tile file not found", path)
    reference, target = read_raster(paths[0]), read_raster(paths[1])
    disparity = read_raster(paths[2], check=False).data.astype(np.float32)
    if disparity.shape != reference.data.shape or target.data.shape != reference.data.shape:
        raise InputError(
            f"US3D tile {name}: images {reference.data.shape}, {target.data.shape} and disparity "
            f"{disparity.shape} differ in size",
            folder,
        )
    disparity[(disparity == US3D_NODATA) | ~np.isfinite(disparity)] = np.nan
    rows_note = "not checked"
    if level:
        levelled = level_rows(Pair(reference, target))
        target, rows_note = levelled.target, levelled.metadata["rows"]
    if crop is not None:
        if crop < 16:
            raise ParamsError(f"crop must be >= 16 px, got {crop}")
        rows, cols = disparity.shape
        r0, c0 = max(0, (rows - crop) // 2), max(0, (cols - crop) // 2)
        window = (slice(r0, r0 + crop), slice(c0, c0 + crop))
        reference = Raster(reference.data[window])
        target = Raster(target.data[window])
        disparity = disparity[window]
    pair = Pair(
        reference, target, disparity=disparity, name=name.lower(), source=folder,
        metadata={
            "origin": f"US3D / DFC2019 Jacksonville tile {name} (Bosch et al. 2019), multi-date WorldView-3",
            "rows": rows_note,
        },
    )
    object_params = {"layer_width": 3.0, "min_area": 1500, **object_params}
    return _with_objects(pair, **object_params)
