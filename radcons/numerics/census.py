"""Dense matching of a rectified pair by census cost and semi-global matching (CNES Pandora).

Satellite stereo pipelines (CNES CARS, NASA's Ames Stereo Pipeline) match with a census
cost: each pixel is described by which of its neighbours are darker than itself (Zabih and
Woodfill 1994), and two pixels cost the Hamming distance of their descriptions. Any
increasing change of the grey levels leaves that description, hence the disparity,
unchanged: what census does not forgive are changes of the local order of grey levels
(noise, blur, shadows, clipping). The costs are regularised by semi-global matching
(Hirschmueller 2008), with CNES Pandora's pipeline (Cournet et al. 2020) and its libsgm
plugin, in the configuration CARS uses: census 5 x 5, SGM P1 = 8 / P2 = 32, winner takes
all, V-fit subpixel refinement, 3 x 3 median filter, and left-right cross-checking.

Pandora is called in memory (its ``xarray`` datasets are built from the arrays); its
results equal those of its command line on the same images written as TIFFs.

Sign convention (the project's): ``reference(x, y) <-> target(x - d, y)``. Pandora's is the
opposite (the reference pixel ``(x, y)`` matches the target at ``x + d``), so Pandora
searches the negated range and its disparities are negated.

References
----------
Zabih, R., Woodfill, J. (1994). Non-parametric local transforms for computing visual
correspondence. ECCV 1994, LNCS 801, 151-158.

Hirschmueller, H. (2008). Stereo processing by semiglobal matching and mutual information.
IEEE TPAMI 30(2), 328-341.

Cournet, M., Sarrazin, E., Dumas, L., Michel, J., Guinet, J., Youssefi, D., Defonte, V.,
Fardet, Q. (2020). Ground-truth generation and disparity estimation for optical satellite
imagery. International Archives of the Photogrammetry, Remote Sensing and Spatial
Information Sciences (ISPRS Congress 2020).
"""

from __future__ import annotations

import contextlib
import functools
import importlib.metadata
import logging
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from radcons.errors import InputError, ParamsError, StageError
from radcons.validate import single_band_image

__all__ = ["CensusParams", "census_disparity", "to_census_input", "census_memory_bytes"]

#: Census windows Pandora accepts.
_WINDOWS = (3, 5, 7, 9, 11, 13)
_REFINEMENTS = ("vfit", "quadratic", "none")
_CROSS_CHECKS = ("accurate", "fast", "none")

#: Percentiles of each image mapped to 0 and 255 by :func:`to_census_input`.
_PERCENTILES = (0.5, 99.5)

#: Peak resident memory of one Pandora run, measured with ``resource.getrusage`` on
#: 512 x 512 and 1024 x 1024 pairs with 64 to 256 disparities: per float32 cost-volume
#: cell (4 bytes), this many times 4 bytes (with cross-checking a second, right cost
#: volume lives beside the first) ...
_CELL_FACTOR = {"accurate": 4.3, "fast": 4.3, "none": 3.3}
#: ... plus this many bytes per pixel (images, masks, disparity maps, indices).
_PIXEL_BYTES = 256


@dataclass(frozen=True)
class CensusParams:
    """Parameters of the census + SGM matcher (CARS' Pandora configuration by default).

    Attributes
    ----------
    window_size : int
        Census window side in pixels, one of 3, 5, 7, 9, 11, 13. The cost of a match is
        the number of the ``window_size**2`` comparisons that differ (0..25 for 5 x 5).
    p1, p2 : float
        SGM penalties (Pandora's ``sgm_penalty``, constant ``P2``) for a disparity change
        of 1 px between neighbours and for a larger one, in census cost units; need
        ``0 < p1 < p2``.
    refinement : {"vfit", "quadratic", "none"}
        Subpixel refinement of the winner-takes-all disparity: a V fit (suited to census'
        piecewise-linear costs) or a parabola through the three costs around the minimum,
        or none (integer disparities).
    median_size : int
        Side of the median filter applied to the disparity map (odd, >= 3), 0 for none.
    cross_check : {"accurate", "fast", "none"}
        Left-right consistency (Pandora's validation step): a pixel whose disparity is not
        found back, within ``cross_check_threshold`` px, from the target's own disparity
        map is invalid (NaN, occlusion or mismatch). "accurate" computes the target's map
        with its own cost volume and SGM (about twice the time and memory); "fast"
        reverses the reference's optimised cost volume; "none" checks nothing.
    cross_check_threshold : float
        Largest left-right difference in px a valid pixel may have.
    memory_limit_gib : float or None
        Largest memory a run may need, in GiB; None takes the memory this machine has
        available when the run starts. A disparity range whose cost volume would need more
        is refused before Pandora starts (see :func:`census_memory_bytes`).
    """

    window_size: int = 5
    p1: float = 8.0
    p2: float = 32.0
    refinement: str = "vfit"
    median_size: int = 3
    cross_check: str = "accurate"
    cross_check_threshold: float = 1.0
    memory_limit_gib: float | None = None

    def __post_init__(self) -> None:
        if self.window_size not in _WINDOWS:
            raise ParamsError(f"census window_size must be one of {_WINDOWS}, got {self.window_size}")
        if not 0 < self.p1 < self.p2:
            raise ParamsError(f"census SGM penalties need 0 < p1 < p2, got p1={self.p1}, p2={self.p2}")
        if self.refinement not in _REFINEMENTS:
            raise ParamsError(f"census refinement must be one of {_REFINEMENTS}, got {self.refinement!r}")
        if self.median_size != 0 and (self.median_size < 3 or self.median_size % 2 == 0):
            raise ParamsError(f"census median_size must be 0 or odd and >= 3, got {self.median_size}")
        if self.cross_check not in _CROSS_CHECKS:
            raise ParamsError(f"census cross_check must be one of {_CROSS_CHECKS}, got {self.cross_check!r}")
        if not self.cross_check_threshold > 0:
            raise ParamsError(f"cross_check_threshold must be positive, got {self.cross_check_threshold}")
        if self.memory_limit_gib is not None and not self.memory_limit_gib > 0:
            raise ParamsError(f"memory_limit_gib must be positive, got {self.memory_limit_gib}")


def to_census_input(image: np.ndarray) -> np.ndarray:
    """Map one image on its own for Pandora: its 0.5-99.5 percentile range to 0..255.

    Census compares each pixel only with its neighbours in the same image, so the two
    images need no common range, and the map is increasing and affine, without clipping:
    it changes no census description (clipping would turn the brightest and darkest
    0.5 % into ties, and the order census relies on would be lost there). It only gives
    every input (8-bit, 11/12-bit, reflectance) the same numeric scale in Pandora's
    float32 pipeline. NaN pixels stay NaN (Pandora's no-data mask).

    Parameters
    ----------
    image : ndarray
        2-D image, any real dtype, NaN where invalid, at least one valid pixel.

    Returns
    -------
    ndarray of float32
    """
    values = image.astype(np.float64)
    finite = values[np.isfinite(values)]
    low, high = (float(v) for v in np.percentile(finite, _PERCENTILES))
    if high <= low:
        low, high = float(finite.min()), float(finite.max())
    scale = 255.0 / (high - low) if high > low else 1.0
    return ((values - low) * scale).astype(np.float32)


def census_memory_bytes(
    shape: tuple[int, int], disparity_range: tuple[float, float], params: CensusParams = CensusParams()
) -> int:
    """Estimated peak memory of one census run: bytes.

    One float32 cost volume holds ``rows * cols * disparities`` cells of 4 bytes; a whole
    Pandora run was measured to peak at about 4.3 times that with cross-checking (3.3
    without), plus about 256 bytes per pixel.

    Parameters
    ----------
    shape : (int, int)
        Image rows and columns.
    disparity_range : (float, float)
        Smallest and largest disparity searched (widened to whole pixels).
    params : CensusParams
    """
    disparities = math.ceil(disparity_range[1]) - math.floor(disparity_range[0]) + 1
    per_pixel = disparities * 4 * _CELL_FACTOR[params.cross_check] + _PIXEL_BYTES
    return int(shape[0] * shape[1] * per_pixel)


def census_disparity(
    reference: np.ndarray,
    target: np.ndarray,
    disparity_range: tuple[float, float],
    params: CensusParams = CensusParams(),
) -> np.ndarray:
    """Dense disparity of the reference by census + SGM (Pandora).

    Parameters
    ----------
    reference, target : ndarray
        Rectified single-band images of the same shape, any real dtype and value range,
        NaN where invalid. Each is mapped on its own by :func:`to_census_input`.
    disparity_range : (float, float)
        Smallest and largest disparity to search (widened to whole pixels).
    params : CensusParams

    Returns
    -------
    ndarray of float32
        Disparity in the reference frame, ``reference(x, y) <-> target(x - d, y)``; NaN
        where Pandora's validity mask marks the pixel invalid: the image border (half the
        census window plus half the median filter), no-data in the reference, no valid
        match in the target, and occlusions and mismatches found by the cross-check.

    Raises
    ------
    InputError
        Images not 2-D of the same shape, not real numbers, without a valid pixel, or
        smaller than the census window.
    ParamsError
        A disparity range that is not finite or whose high end is below its low end, or
        one whose cost volume needs more memory than is available.
    StageError
        Pandora failed; the message carries Pandora's.
    """
    small = f"is smaller than the census window ({params.window_size} px)"
    reference = single_band_image(reference, "reference", params.window_size, small)
    target = single_band_image(target, "target", params.window_size, small)
    if reference.shape != target.shape:
        raise InputError(
            f"dense matching needs two images of the same shape, got {reference.shape} and {target.shape}"
        )
    low, high = (float(v) for v in disparity_range)
    if not (math.isfinite(low) and math.isfinite(high) and high >= low):
        raise ParamsError(f"disparity_range must be finite with high >= low, got {disparity_range}")
    _check_memory(reference.shape, (low, high), params)
    d_min, d_max = math.floor(low), math.ceil(high)
    with _quiet_pandora():
        pandora_disparity, invalid = _run_pandora(
            to_census_input(reference), to_census_input(target), [-d_max, -d_min], [d_min, d_max], params
        )
    disparity = 0.0 - pandora_disparity.astype(np.float32)
    disparity[invalid] = np.nan
    return disparity


def _check_memory(shape: tuple[int, int], disparity_range: tuple[float, float], params: CensusParams) -> None:
    """Refuse a run whose cost volumes would not fit in the memory allowed."""
    needed = census_memory_bytes(shape, disparity_range, params)
    if params.memory_limit_gib is not None:
        allowed, what = params.memory_limit_gib * 2**30, "the memory limit"
    else:
        allowed, what = _available_memory(), "the memory available"
    if needed > allowed:
        raise ParamsError(
            f"census matching of {shape[0]} x {shape[1]} px over the disparity range "
            f"{disparity_range[0]:g}..{disparity_range[1]:g} would need about {needed / 2**30:.1f} GiB, "
            f"more than {what} ({allowed / 2**30:.1f} GiB): narrow the range or match in tiles"
        )


def _available_memory() -> float:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``, else free pages)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))


@contextlib.contextmanager
def _quiet_pandora() -> Iterator[None]:
    """Silence the state-machine library's warnings Pandora triggers on every new machine."""
    logger = logging.getLogger("transitions.core")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _pipeline(params: CensusParams) -> dict[str, dict]:
    """Pandora's ``pipeline`` configuration section for ``params``."""
    pipeline: dict[str, dict] = {
        "matching_cost": {"matching_cost_method": "census", "window_size": params.window_size, "subpix": 1},
        "optimization": {
            "optimization_method": "sgm",
            "penalty": {"P1": params.p1, "P2": params.p2, "p2_method": "constant", "penalty_method": "sgm_penalty"},
        },
        "disparity": {"disparity_method": "wta", "invalid_disparity": "NaN"},
    }
    if params.refinement != "none":
        pipeline["refinement"] = {"refinement_method": params.refinement}
    if params.median_size:
        pipeline["filter"] = {"filter_method": "median", "filter_size": params.median_size}
    if params.cross_check != "none":
        pipeline["validation"] = {
            "validation_method": f"cross_checking_{params.cross_check}",
            "cross_checking_threshold": params.cross_check_threshold,
        }
    return pipeline


@functools.cache
def _load_plugins() -> None:
    """Load Pandora's plugins (libsgm) once a process, and give Pandora two faster equivalents.

    The libsgm plugin also looks its C++ optimiser up among every installed distribution's
    entry points each time an SGM step is built, twice a run (8 ms each here, 0.05 s of a
    1024 x 1024 px pair's height objects). The answer cannot change within a process, so
    the plugin is given a cached lookup. Pandora's median filter is given
    :func:`_median_filter`, which returns the same values 4.5 times faster.
    """
    import pandora
    from pandora.filter.median import MedianFilter
    from pandora_plugin_libsgm import abstract_sgm

    pandora.import_plugin()
    abstract_sgm.entry_points = _cached_entry_points
    MedianFilter.median_filter = _median_filter


#: Window values sorted at once by :func:`_median_filter` (bounds its memory: 4 M float32
#: values, 16 MiB, besides the disparity map, where a whole 4096 x 4096 px map would take 575 MiB).
_MEDIAN_CHUNK_VALUES = 1 << 22


def _median_filter(self, data: np.ndarray) -> np.ndarray:
    """Pandora's median filter (``MedianFilter.median_filter``): the same values, by one sort.

    Each pixel whose ``filter_size`` window lies inside the image takes the median of the
    window's valid (non-NaN) disparities, the mean of the two middle ones when their
    count is even; border pixels keep their value and NaN stays NaN. The rows are sorted
    in blocks of :data:`_MEDIAN_CHUNK_VALUES` values. Pandora computes the same with
    ``numpy.nanmedian`` over masked arrays, in blocks of 100 x 100 px, which
    took a fifth of each census run of the height method: 0.049 s against 0.011 s here on
    a 256 x 256 px disparity, 0.71 s against 0.16 s at 1024 x 1024
    (``benchmarks/bench_matchers.py --median``).
    """
    size = self._filter_size
    radius = size // 2
    out = np.copy(data)
    rows, cols = data.shape[0] - 2 * radius, data.shape[1] - 2 * radius
    if rows > 0 and cols > 0:
        windows = np.lib.stride_tricks.sliding_window_view(data, (size, size))  # a view: no copy yet
        step = max(1, _MEDIAN_CHUNK_VALUES // (cols * size * size))  # rows sorted at once
        for start in range(0, rows, step):
            block = windows[start : start + step].reshape(-1, cols, size * size)
            ordered = np.sort(block, axis=-1)  # NaN sorts last
            count = np.count_nonzero(~np.isnan(block), axis=-1)
            low = np.take_along_axis(ordered, (np.maximum(count - 1, 0) // 2)[..., None], axis=-1)[..., 0]
            high = np.take_along_axis(ordered, (count // 2)[..., None], axis=-1)[..., 0]
            median = np.where(count > 0, (low + high) / 2, np.nan)
            out[radius + start : radius + start + len(block), radius : radius + cols] = median
    out[np.isnan(data)] = np.nan
    return out


@functools.cache
def _cached_entry_points(**selection: str):
    """``importlib.metadata.entry_points(**selection)``, looked up once a process."""
    return importlib.metadata.entry_points(**selection)


def _run_pandora(
    left: np.ndarray, right: np.ndarray, left_range: list[int], right_range: list[int], params: CensusParams
) -> tuple[np.ndarray, np.ndarray]:
    """Run Pandora on two mapped images: its left disparity map and where it is invalid."""
    import pandora
    from pandora.check_configuration import check_datasets, check_pipeline_section
    from pandora.criteria import Criteria
    from pandora.state_machine import PandoraMachine

    try:
        _load_plugins()
        machine = PandoraMachine()
        left_image, right_image = _image_dataset(left, left_range), _image_dataset(right, right_range)
        check_datasets(left_image, right_image)
        config = check_pipeline_section(
            {"pipeline": _pipeline(params)},
            _metadata(left.shape, left_range),
            _metadata(right.shape, right_range),
            machine,
        )
        result, _ = pandora.run(machine, left_image, right_image, config)
        invalid = (result["validity_mask"].data & int(Criteria.PANDORA_MSK_PIXEL_INVALID)) != 0
        return result["disparity_map"].data.copy(), invalid
    except MemoryError as error:
        raise StageError(f"Pandora ran out of memory: narrow the disparity range or match in tiles ({error})") from error
    except Exception as error:  # Pandora's own failures, of any type, become one line
        message = " ".join(str(error).split()) or type(error).__name__
        raise StageError(f"Pandora census matching failed: {message}") from error
    finally:
        # Pandora's state machine is a reference cycle (its transitions refer back to it)
        # that holds the cost volumes and datasets: drop what it holds, so that they are
        # freed now and not at the next full collection, which repeated calls would wait on
        if "machine" in locals():
            machine.__dict__.clear()


def _image_dataset(image: np.ndarray, disparity_range: list[int]):
    """Pandora's image dataset, as its ``create_dataset_from_inputs`` builds from a file."""
    import xarray as xr
    from pandora.img_tools import add_disparity, add_mask, add_no_data

    rows, cols = image.shape
    dataset = xr.Dataset(
        {"im": (["row", "col"], image)},
        coords={"row": np.arange(rows), "col": np.arange(cols)},
        attrs={"crs": None, "transform": None, "valid_pixels": 0, "no_data_mask": 1},
    )
    no_data = np.nonzero(np.isnan(image))
    return (
        dataset.pipe(add_disparity, disparity=disparity_range, window=None)
        .pipe(add_no_data, np.nan, no_data)
        .pipe(add_mask, None, no_data, cols, rows, None)
    )


def _metadata(shape: tuple[int, int], disparity_range: list[int] | None):
    """The image description Pandora checks a pipeline against (its ``get_metadata``)."""
    import xarray as xr
    from pandora.img_tools import add_disparity

    return xr.Dataset(
        coords={"band_im": [None], "row": np.arange(shape[0]), "col": np.arange(shape[1])}
    ).pipe(add_disparity, disparity=disparity_range, window=None)
