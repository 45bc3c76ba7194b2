"""What every part of the report shares: the compared methods, the metrics, the colours,
the settings of a run and one evaluated pair."""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace
from pathlib import Path

from radcons.numerics.census import CensusParams
from radcons.evaluate.compare import Comparison
from radcons.evaluate.matching import MatcherParams, matcher_name
from radcons.io import Pair

#: The checkout's root folder.
REPO = Path(__file__).resolve().parents[2]

#: Demo scenarios evaluated (``none``, same date and sensor, only gives the ceiling).
SCENARIOS: tuple[str, ...] = ("multi-temporal", "multi-sensor", "mixed")
#: Baselines, in table order.
BASELINE_NAMES: tuple[str, ...] = ("histmatch", "meanstd", "irmad", "zhang", "zhong")
#: Methods of every table, in column order.
COMPARED: tuple[str, ...] = ("original", *BASELINE_NAMES, "paper", "ours")
#: Image stages of the ablation; the last stage's images are "ours".
ABLATION: tuple[str, ...] = ("original", "uniformity", "global", "refine", "sharpness", "ours")
ABLATION_LABELS = {
    "original": "original",
    "uniformity": "+ uniformity (eq 1-3)",
    "global": "+ global (eq 4-6)",
    "refine": "+ refine (eq 7-12)",
    "sharpness": "+ sharpness (not the paper's)",
    "ours": "+ smoothness (eq 13-19) = ours",
}
#: The paper's means over its 9 building objects (Su et al. 2018, Tables 1 and 2).
PAPER_MEANS = {
    "similarity": {"original": 0.807, "zhang": 0.811, "zhong": 0.835, "ours": 0.920},
    "object_rate": {"original": 0.287, "zhang": 0.242, "zhong": 0.337, "ours": 0.572},
}
#: Metrics of the summary tables: key -> (label, MethodResult attribute).
METRICS = {
    "similarity": ("mean object similarity C (eq 20)", "mean_similarity"),
    "rate": ("correct-matching rate, all pixels with ground truth", "correct_rate"),
    "object_rate": ("correct-matching rate, mean over objects", "mean_object_rate"),
}
#: Bar and legend colours (BGR) per method.
COLOURS = {
    "undegraded": (160, 160, 160),
    "original": (90, 90, 90),
    "histmatch": (60, 160, 230),
    "meanstd": (40, 200, 200),
    "irmad": (180, 120, 60),
    "zhang": (200, 90, 160),
    "zhong": (120, 60, 200),
    "paper": (150, 200, 90),
    "ours": (40, 150, 40),
}
#: Differences below this are ties at the report's three decimals.
TIE = 5e-4


@dataclass(frozen=True)
class Settings:
    """What one report run evaluates."""

    size: int
    seeds: tuple[int, ...]
    motorcycle_downsample: int
    pleiades_crop: int | None
    preset: str
    matchers: tuple[MatcherParams | CensusParams, ...]
    data: Path
    out: Path
    quick: bool

    @property
    def matcher(self) -> MatcherParams | CensusParams:
        """The first matcher: the one of the figures and of the Pleiades reference disparity."""
        return self.matchers[0]

    @property
    def matcher_names(self) -> tuple[str, ...]:
        """The matchers' names, in the report's order."""
        return tuple(matcher_name(m) for m in self.matchers)


@dataclass
class Entry:
    """One evaluated pair: its comparisons, pipeline timings and how it was built.

    ``comparisons`` holds one comparison per matcher; ``comparison`` is the one the
    report's sections read (the first matcher's, or the one :func:`for_matcher` picks).
    """

    key: str
    title: str
    pair: Pair
    comparison: Comparison
    timings: dict[str, float]
    built: str
    objects: str
    extra: dict
    comparisons: dict[str, Comparison]


def for_matcher(entry: Entry, name: str) -> Entry:
    """The entry as seen with matcher ``name``: its ``comparison`` is that matcher's.

    Parameters
    ----------
    entry : Entry
    name : str
        A key of ``entry.comparisons``.

    Returns
    -------
    Entry
    """
    return replace(entry, comparison=entry.comparisons[name])


def log(message: str) -> None:
    """Print a progress message to standard error at once.

    Parameters
    ----------
    message : str
        The message, one line.
    """
    print(message, file=sys.stderr, flush=True)
