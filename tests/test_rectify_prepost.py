"""Raw pairs whose matches share rows on average are still rectified: the Kahramanmaras pre/post crops.

``radcons process REF.tif TGT.tif`` takes two images of equal sizes as rectified unless the
median vertical parallax of their SIFT matches exceeds 8 px (:mod:`radcons.geometry`). The
raw Kahramanmaras pair ``pre_event_img2`` / ``post_event_img2`` (two views of nearly the
same direction, seven years apart) has a median of 5.9 px, but the plane of vertical offset
fitted on its matches reaches 10.5 px: its rows do not correspond, and it must go through
the rectify stage like the other pre/post combinations
(``benchmarks/bench_rectify_rpc.py``: fresh SIFT matches of the output, Lowe ratio 0.75,
``|dy|`` 90th percentile).
"""

from __future__ import annotations

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.geometry import median_vertical_parallax, settle_geometry
from radcons.io import load_pair_files, write_raster
from radcons.params import DEFAULT_PRESET, Params
from radcons.pipeline import Pipeline
from radcons.stages.rectify.features import match_sift
from radcons.stages.rectify.params import UNRECTIFIED_PARALLAX_PX
from radcons.stages.rectify.row_levelling import level_target, measure_row_offset
from radcons.stages.rectify.run import RectifyParams


def _row_p90(reference: np.ndarray, target: np.ndarray) -> tuple[float, int]:
    """``|dy|`` 90th percentile of fresh SIFT matches (ratio 0.75) within 3 px of a common row, and their count."""
    matches = match_sift(reference, target, RectifyParams(ratio=0.75))
    dy = np.abs(matches.ref_xy[:, 1].astype(np.float64) - matches.tgt_xy[:, 1])
    kept = dy[dy <= 3.0]
    return float(np.percentile(kept, 90)), int(kept.size)


def test_rows_tilted_beyond_the_threshold_make_a_pair_unrectified(tmp_path):
    demo = generate(size=256, seed=0, scenario="none")
    tilted = level_target(demo.target.as_float32(), (0.05, 0.0, 0.0))  # 0 px at the left edge, 12.8 at the right
    parallax, _ = median_vertical_parallax(demo.reference.as_float32(), tilted)
    offset = measure_row_offset(demo.reference.as_float32(), tilted)
    assert parallax < UNRECTIFIED_PARALLAX_PX < offset.largest and offset.unrectified and not offset.applied
    files = (write_raster(tmp_path / "a.tif", demo.reference.data), write_raster(tmp_path / "b.tif", tilted))
    pair = settle_geometry(load_pair_files(*files))
    assert not pair.rectified and "plane of vertical offset" in pair.metadata["geometry"]
    assert "rows" not in pair.metadata  # nothing levelled: the rectify stage takes the pair


@pytest.mark.realdata
@pytest.mark.slow
def test_pre2_post2_goes_through_the_rpc_route_and_shares_rows(shared_data):
    folder = shared_data / "pleiades_kahramanmaras_prepost"
    pair = settle_geometry(load_pair_files(folder / "pre_event_img2.tif", folder / "post_event_img2.tif"))
    assert not pair.rectified, pair.metadata
    rectification = Pipeline(Params.from_preset(DEFAULT_PRESET)).run(pair, until="rectify").rectification
    assert rectification.method == "rpc"
    p90, kept = _row_p90(rectification.reference, rectification.target)
    assert kept >= 100 and p90 < 1.0  # 2.6 px over 116 matches when the raw pair was taken as rectified
