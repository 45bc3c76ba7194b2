"""The stages of the method, one module each (see :mod:`radcons.pipeline`)."""

#: Stage names in pipeline order; also the parameter file's table names.
STAGES: tuple[str, ...] = (
    "rectify", "objects", "association", "uniformity", "global", "refine", "sharpness", "smoothness",
)
