"""Radiometric normalisation methods the paper's method is compared with.

Each is a function ``(reference, target) -> normalised target`` on float32 images with NaN
where invalid (NaN kept), registered in :data:`BASELINES` with its default parameters:

* ``histmatch``: histogram matching (``skimage.exposure.match_histograms``);
* ``meanstd``: mean and standard deviation matching;
* ``irmad``: IR-MAD relative normalisation (Canty and Nielsen 2008);
* ``zhang``: two-layer contrast and brightness normalisation, reconstructed after Zhang,
  Chen and Sun (2014);
* ``zhong``: hierarchical regression, reconstructed after Zhong, Xu and Li (2016).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from radcons.baselines.irmad import irmad_normalisation
from radcons.baselines.statistics import histogram_matching, mean_std_matching
from radcons.baselines.zhang import zhang_normalisation
from radcons.baselines.zhong import zhong_normalisation

__all__ = ["BASELINES"]

#: Baseline name -> ``(reference, target) -> normalised target``.
BASELINES: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "histmatch": histogram_matching,
    "meanstd": mean_std_matching,
    "irmad": irmad_normalisation,
    "zhang": zhang_normalisation,
    "zhong": zhong_normalisation,
}
