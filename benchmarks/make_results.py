"""Regenerate the results report: ``docs/results.md``, ``docs/results.json`` and ``docs/img/``.

One command runs every evaluation of the report and writes it; no number in the report is
typed by hand. What it runs:

* synthetic pairs of :mod:`demo_data_gen` (scenarios ``multi-temporal``, ``multi-sensor``,
  ``mixed``; several seeds) with their exact ground truth, every method of
  :data:`results_report.common.COMPARED`, and the per-stage ablation on ``mixed``;
* real stereo pairs with real ground truth (Middlebury Cones from the shared data folder,
  Middlebury Motorcycle from scikit-image) whose target gets the simulated date / sensor
  difference of ``benchmarks/bench_baselines.py``;
* the real, epipolar-rectified Pleiades pair over La Reunion, without ground truth: the
  reference disparity is the left-right checked SGBM disparity of the clean pair, and the
  target gets the same kind of simulated difference;
* the paper's own means beside ours, plots, and a computed list of where the method does
  not win;
* every pair again with its labels withheld from the pipeline, objects segmented from the
  images (``mbi``) or found from height (``height``): :mod:`results_report.segmented`,
  added to the written report.

Usage::

    python benchmarks/make_results.py            # the report, into docs/
    python benchmarks/make_results.py --quick    # smoke run (small, one seed), into a temp folder

Options: ``--data`` (shared data folder; default ``$RADCONS_DATA`` or ``../shared/data``
beside the checkout), ``--out`` (folder of ``results.md``), ``--preset``, ``--size``,
``--seeds``.

The work is done by the package ``results_report`` beside this script (its modules: the runs,
the tables, the sections, the figures and the page).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# the checkout's packages first, so the script runs from the source tree as it is; Python
# puts this script's folder on the path too, for results_report and bench_baselines
sys.path.insert(0, str(REPO))

from radcons.numerics.census import CensusParams  # noqa: E402
from radcons.evaluate.matching import MatcherParams  # noqa: E402
from radcons.params import DEFAULT_PRESET, PRESETS  # noqa: E402
from results_report.common import Settings  # noqa: E402
from results_report.page import write_report  # noqa: E402
from results_report.run import shared_data_dir  # noqa: E402
from results_report.segmented import write_segmented  # noqa: E402


def parse(argv: list[str]) -> Settings:
    """The report's settings from the command line.

    Parameters
    ----------
    argv : list of str
        The command's arguments (without the program name).

    Returns
    -------
    Settings
        What to evaluate, with the ``--quick`` defaults where asked.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small images, one seed, into a temp folder")
    parser.add_argument("--data", help="shared data folder (default $RADCONS_DATA or ../shared/data)")
    parser.add_argument("--out", help="folder of results.md (default docs/, or a temp folder with --quick)")
    parser.add_argument("--preset", default=DEFAULT_PRESET, choices=PRESETS, help="parameter preset of ours")
    parser.add_argument("--size", type=int, help="demo image size (default 512, 256 with --quick)")
    parser.add_argument("--seeds", type=int, nargs="+", help="demo seeds (default 0 1 2, 0 with --quick)")
    args = parser.parse_args(argv)
    quick = args.quick
    out = Path(args.out) if args.out else (
        Path(tempfile.gettempdir()) / "radcons-results-quick" if quick else REPO / "docs"
    )
    return Settings(
        size=args.size or (256 if quick else 512),
        seeds=tuple(args.seeds or ((0,) if quick else (0, 1, 2))),
        motorcycle_downsample=4 if quick else 2,
        pleiades_crop=384 if quick else None,
        preset=args.preset,
        matchers=(MatcherParams(), CensusParams()),
        data=shared_data_dir(args.data),
        out=out,
        quick=quick,
    )


def main(argv: list[str] | None = None) -> None:
    """Write the results report.

    Parameters
    ----------
    argv : list of str, optional
        The command's arguments; default ``sys.argv[1:]``.
    """
    argv = sys.argv[1:] if argv is None else argv
    settings = parse(argv)
    write_report(settings, argv)
    write_segmented(settings)


if __name__ == "__main__":
    main()
