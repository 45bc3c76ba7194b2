"""The smoothness stage: both images brought to one noise level by union group sparse denoising.

Su et al. (2018), section 5, eq 13-19: each reference patch, with its most similar patches
(block matching), forms a group whose centred singular values are soft-thresholded and
whose patch estimates are averaged (the group sparse model, eq 13-16). The union group
stacks the groups of an associated object's reference patch and of its partner in the
target at the object's modal disparity D̄m; its singular values give the thresholds of
eq 17 (SAIST's bilateral variance estimate), and the same thresholds denoise both images,
which thus end at one smoothness level. Eq 18-19 iterate with regularisation and a
falling noise level.

Modules:

- :mod:`~radcons.stages.smoothness.params`: :class:`SmoothnessParams`;
- :mod:`~radcons.stages.smoothness.run`: the regions, the union groups' centre patches,
  the iterations (:func:`~radcons.stages.smoothness.run.smoothness_consistency`), the
  single-image model and the preview for live tuning;
- :mod:`~radcons.stages.smoothness.patch_matching`: block matching inside an object's
  region (compiled);
- :mod:`~radcons.stages.smoothness.group_sparse`: the group estimates of eq 15-17 and the
  passes over an image (compiled);
- :mod:`~radcons.stages.smoothness.group_sparse_linalg`: the groups' largest Gram
  eigenvalues (Householder tridiagonalisation, Sturm bisection, QL);
- :mod:`~radcons.stages.smoothness.inverse_iteration`: the eigenvectors of the surviving
  singular values;
- :mod:`~radcons.stages.smoothness.step`: the pipeline's call.

References: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 5; Dong, Shi,
Li (2013), "Nonlocal image restoration with bilateral variance estimation: a low-rank
approach", IEEE Trans. Image Process. 22(2), 700-711 (SAIST).
"""

from radcons.stages.smoothness.params import SmoothnessParams

__all__ = ["SmoothnessParams"]
