"""What the ``bench_objects.py`` sections share: the measures and the pairs they read.

The measures compare objects with the demo generator's buildings (:func:`building_ious`,
:func:`object_precision`, :func:`in_both_images`, :func:`dominant_disparity`) and with
the US3D tiles' lidar (:func:`lidar_truth`).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from radcons.numerics.modal import modal_disparity
from radcons.stages.objects.ground import ground_disparity
from radcons.stages.objects.run import ObjectsParams, height_objects

if TYPE_CHECKING:
    from radcons.params import Params

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
#: The US3D tiles, with lidar disparity, and their folder.
US3D = DATA / "us3d_jacksonville_multidate"
US3D_TILES = ("JAX_072_011_022", "JAX_122_019_005")
HEIGHT = ObjectsParams(method="height")
#: Short names of the rules of :data:`radcons.stages.objects.rules.LEFT_OUT_RULES`, for the real pairs' table.
RULE_NAMES = {1: "tree", 2: "low", 3: "contrast", 4: "shadow", 5: "no edge", 6: "dark and low", 7: "green", 8: "crowns"}


def majority(labels: np.ndarray, mask: np.ndarray) -> int:
    """The label most of ``mask``'s pixels carry (0 when ``mask`` is empty)."""
    under = labels[mask]
    return int(np.bincount(under).argmax()) if under.size else 0


def building_ious(truth: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """For each true building, the IoU with the object that covers most of it (0 if none)."""
    out = []
    for ident in np.unique(truth[truth > 0]):
        mask = truth == ident
        under = labels[mask]
        under = under[under > 0]
        if under.size == 0:
            out.append(0.0)
            continue
        other = labels == np.bincount(under).argmax()
        out.append((mask & other).sum() / (mask | other).sum())
    return np.array(out)


def in_both_images(pair) -> np.ndarray:
    """For each true building, whether the target shows it too.

    A building the target cannot show is no object of the pair: one demolished or built
    between the dates (more than half of it in the generator's ``change_mask``), or one
    of which the target sees less than 70 % at its true disparity: pixels outside the
    target's frame (the reference's left strip, ``x - d < 0``) or hidden there (the
    generator's disparity is NaN where the target does not see the point).
    """
    truth = pair.reference_objects
    columns = np.arange(truth.shape[1])[None, :].repeat(truth.shape[0], axis=0)
    shown = []
    for ident in np.unique(truth[truth > 0]):
        mask = truth == ident
        disparity = pair.disparity[mask]
        inside = columns[mask] - np.nan_to_num(disparity, nan=np.inf) >= 0
        shown.append(pair.change_mask[mask].mean() <= 0.5 and inside.mean() >= 0.7)
    return np.array(shown, bool)


def dominant_disparity(disparities: np.ndarray) -> bool:
    """Whether at least half of an object's true disparities lie within 1 px of their mode (:func:`modal_disparity`).

    A pitched roof spreads its disparities evenly from eaves to ridge: its 1 px mode is
    then one of several near-equal bins, and its median says where the roof stands.
    """
    return bool(np.mean(np.abs(disparities - modal_disparity(disparities)) <= 1.0) >= 0.5)


def object_precision(truth: np.ndarray, labels: np.ndarray, min_px: int = 100) -> tuple[int, int]:
    """(objects of >= min_px that are a building at IoU 0.5, objects of >= min_px)."""
    good = total = 0
    for ident in np.unique(labels[labels > 0]):
        mask = labels == ident
        if mask.sum() < min_px:
            continue
        total += 1
        building = majority(truth, mask)
        if building:
            other = truth == building
            good += int((mask & other).sum() / (mask | other).sum() >= 0.5)
    return good, total


@functools.lru_cache(maxsize=None)
def demo_objects(size: int, scenario: str, seed: int):
    """A demo pair and its height objects (labels withheld, the pair's GSD and base-to-height ratio).

    Kept for the run: the ``demo``, ``misses`` and ``trees`` sections read the same objects, found once.
    """
    from demo_data_gen import generate

    pair = generate(size=size, seed=seed, scenario=scenario)
    meta = pair.metadata
    found = height_objects(
        pair.reference.as_float32(), pair.target.as_float32(), HEIGHT,
        gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"],
    )
    return pair, found


def radcons_preset(settings: list[str] | tuple[str, ...] = ()) -> Params:
    """The ``radcons`` preset with ``STAGE.KEY=VALUE`` changes (TOML values), as ``--set``
    gives them (:func:`bench_generalisation.radcons_variant`)."""
    from bench_generalisation import radcons_variant

    return radcons_variant(list(settings))


def lidar_truth(pair, lidar: Path, tree_greenness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A US3D tile's lidar truth on its reference's grid: known, elevated and built pixels.

    Elevated: the lidar disparity stands more than 2 px above the lidar's own ground
    (:func:`ground_disparity` in 400 px windows); built: elevated and not green (green
    leaf index of the pair's reference at most ``tree_greenness``). -999 is no data.
    """
    from radcons.io import read_raster

    dsp = read_raster(lidar, check=False).data.astype(np.float32)
    dsp[dsp <= -999] = np.nan
    ground = ground_disparity(dsp, 400, 10.0, 2.0)
    elevated = (dsp - ground) > 2.0
    known = np.isfinite(dsp)
    built = elevated & known & ~(np.nan_to_num(pair.reference.greenness, nan=0.0) > tree_greenness)
    return known, elevated, built
