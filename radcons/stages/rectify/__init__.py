"""The rectify stage: epipolar resampling of a pair that is not rectified.

Its modules, in the order they run:

- :mod:`~radcons.stages.rectify.params`: :class:`RectifyParams`, and the thresholds the
  modules share (interpolations, the parallax of an unrectified pair).
- :mod:`~radcons.stages.rectify.step`: what the pipeline calls; nothing to do for a pair
  given rectified.
- :mod:`~radcons.stages.rectify.run`: :func:`~radcons.stages.rectify.run.rectify_pair`
  chooses the route (RPC models, else the images) and returns the rectification with its
  maps to and from the original geometry.
- :mod:`~radcons.stages.rectify.rpc_grids` and :mod:`~radcons.stages.rectify.rpc`: the
  RPC route: shareloc's epipolar grids, then SIFT matches that check the models and
  correct their pointing; :class:`~radcons.stages.rectify.rpc_grids.RpcMisfit` sends the
  pair to the affine route.
- :mod:`~radcons.stages.rectify.epipolar`: the affine route: SIFT matches, the affine
  fundamental matrix by RANSAC, the rectifying maps and the NaN-aware resampling both
  routes use.
- :mod:`~radcons.stages.rectify.orientation`: which way up the affine route turns the
  pair, from the skew of its relief.
- :mod:`~radcons.stages.rectify.row_levelling`: the plane of vertical offset that the RPC
  route's pointing correction fits, also used (:mod:`radcons.geometry`) to level the rows
  of a pair given rectified, and to tell a raw pair of equal sizes from a rectified one.
"""

from radcons.stages.rectify.params import RectifyParams

__all__ = ["RectifyParams"]
