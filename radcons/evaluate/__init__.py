"""Evaluation of a pair's radiometric consistency: similarity, dense matching, rates.

The dense matchers share one interface (:mod:`radcons.evaluate.matching`): pick one by
name from :data:`MATCHERS` (``matcher_params("census")``) and run it with
:func:`dense_disparity`.
"""

from radcons.evaluate.matching import (
    MATCHERS,
    MatcherParams,
    dense_disparity,
    matcher_name,
    matcher_params,
)
from radcons.numerics.census import CensusParams, census_disparity

__all__ = [
    "MATCHERS",
    "CensusParams",
    "MatcherParams",
    "census_disparity",
    "dense_disparity",
    "matcher_name",
    "matcher_params",
]
