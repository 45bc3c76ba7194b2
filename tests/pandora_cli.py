"""Pandora's own command line, run as a user would, to check the in-memory census matcher."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import rasterio


def run_pandora_cli(command: Path, left: Path, right: Path, low: int, high: int, out: Path) -> tuple[np.ndarray, np.ndarray]:
    """Run ``pandora CONFIG OUT`` with radcons' census defaults on two float32 TIFFs.

    The configuration is CARS' census pipeline (census 5 x 5, SGM P1 8 / P2 32, WTA, V-fit,
    median 3, accurate cross-check), which is what ``CensusParams()`` asks of Pandora's API.
    Pandora searches the negated range of the project's ``low..high``.

    Returns
    -------
    (ndarray, ndarray)
        Pandora's left disparity in its own sign, and its validity mask.
    """
    config = {
        "input": {
            "left": {"img": str(left), "nodata": float("nan"), "disp": [-high, -low]},
            "right": {"img": str(right), "nodata": float("nan")},
        },
        "pipeline": {
            "matching_cost": {"matching_cost_method": "census", "window_size": 5, "subpix": 1},
            "optimization": {
                "optimization_method": "sgm",
                "penalty": {"P1": 8, "P2": 32, "p2_method": "constant", "penalty_method": "sgm_penalty"},
            },
            "disparity": {"disparity_method": "wta", "invalid_disparity": "NaN"},
            "refinement": {"refinement_method": "vfit"},
            "filter": {"filter_method": "median", "filter_size": 3},
            "validation": {"validation_method": "cross_checking_accurate"},
        },
    }
    path = out.parent / f"{out.name}.json"
    path.write_text(json.dumps(config))  # NaN as JSON's NaN, which Pandora reads
    run = subprocess.run([str(command), str(path), str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    with rasterio.open(out / "left_disparity.tif") as src:
        disparity = src.read(1)
    with rasterio.open(out / "left_validity_mask.tif") as src:
        validity = src.read(1)
    return disparity, validity
