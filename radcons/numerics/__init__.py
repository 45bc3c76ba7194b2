"""Numerics shared by the stages, below them all: none of these modules imports a stage.

- :mod:`~radcons.numerics.census`: census + SGM by CNES Pandora, the census cost;
- :mod:`~radcons.numerics.coarse_disparity`: a coarse census disparity of a pair as given,
  percentile surfaces under it;
- :mod:`~radcons.numerics.modal`: the modal disparity D̄m;
- :mod:`~radcons.numerics.nearest`: approximate nearest descriptors (FLANN), reproducible;
- :mod:`~radcons.numerics.poisson`: the DCT Poisson solver (Neumann boundary) of eq 3;
- :mod:`~radcons.numerics.subpixel`: parabola peaks;
- :mod:`~radcons.numerics.stretch`: robust 8-bit stretches;
- :mod:`~radcons.numerics.labels`: renumbering of label rasters;
- :mod:`~radcons.numerics.valid_pixels`: clipped pixels, blurs that respect nodata, shares
  of the pair's overlap.
"""
