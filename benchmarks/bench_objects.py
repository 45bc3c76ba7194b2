"""Objects from height against the demo generator's buildings, its speed, and the real pairs.

Sections (all by default, or the ones named with ``--only``):

``demo``
    Demo pairs (``--scenarios``, ``--seeds``, ``--sizes``), their label rasters withheld,
    objects by :func:`radcons.stages.objects.run.height_objects` with the pair's GSD and
    base-to-height ratio. Per pair and in total: mean best-match IoU per reference
    building (the IoU with the object covering most of it, 0 if none), recall at IoU 0.5,
    the share of objects of 100 px or more that are a building at IoU 0.5, and the same
    IoU for the image-only MBI path (``method = "mbi"``, today's). Associations
    (:func:`radcons.stages.association.height.associate_by_height` on SIFT matches): an
    association of an object whose reference pixels are mostly one building is correct
    when its target object's pixels are mostly that building in the target's own
    labels; ``D̄m within 1 px``: share of associated objects whose D̄m is within 1 px of
    the modal ground-truth disparity over the object (:func:`modal_disparity`); then the
    same share over the objects not mostly on ground changed between the dates (the
    generator's ``change_mask``), an object without a dominant disparity
    (:func:`dominant_disparity`) counted right within 1 px of its median too; and D̄m on
    the flat roofs (objects over 90 % on one building whose true disparities spread less
    than 0.5 px) and on the pitched ones (no dominant disparity), where the 1 px mode of
    disparities spread evenly from eaves to ridge is decided by bins a few per cent
    apart. Then the mean IoU and recall by the buildings' footprint (m²): where the
    method falls short; and the IoU and recall over the buildings the target shows too
    (:func:`in_both_images`), the ones a pair's objects can be.
``misses``
    The demo buildings of ``demo`` that no object finds (IoU < 0.5), each counted once,
    by the first cause that fits: the target does not show it (:func:`in_both_images`);
    under 100 m² and cut by the image frame; left out by a rule (the rule of
    :attr:`radcons.stages.objects.regions.HeightObjects.left_out` that covers most of
    it, when the rules cover over 30 % of it); partly found (objects cover over 30 %
    of it); no object there. And how many misses a recall of 0.85 allows: what is left
    to find, and where.
``trees``
    The elevated regions of the 512 px pairs before the tree rule, each called a
    building when its pixels are mostly one building: how many the rule removes, of
    which how many were buildings, and the medians of texture, rectangularity, height
    roughness (plane residual) and hull rectangularity of buildings and others.
``timing``
    Objects + association (census disparity, regions, transfer, SIFT matches,
    association) on the 1024 x 1024 ``mixed`` pair, median of ``--repeat`` runs, after a
    first run that pays Pandora's compile time: the two functions one after the other,
    and the ``radcons`` preset's pipeline up to the association (a new
    :class:`radcons.pipeline.Pipeline` each run, so nothing cached), which matches SIFT
    beside the objects; the image-only path (MBI of both images, SIFT, template
    association) measured in the same process as the reference. Two more rows say
    where the time goes: the height method's census disparity alone, and the SIFT
    matching alone with OpenCV on one thread, as it runs beside the objects on the
    other core. And the objects stage run again by one pipeline with a rule's threshold
    changed each time (``tree_texture``), as an analyst tuning it in the inspector does:
    the pipeline keeps the pair's census matching
    (:class:`radcons.stages.objects.matching.PairMatching`). Each row also gives the CPU time of
    all the process's threads (median), and the preset's first run's CPU time over the
    machine's cores: the least wall time any overlap of its threads could reach.
``real``
    The real pairs of ``../shared/data`` (Gizeh, Kahramanmaras pre/post, Mont Ventoux:
    wooded slopes without a building, La Reunion: rectified, a road on steep wooded
    volcanic slopes without a building, US3D Jacksonville) through the ``radcons`` preset with ``objects.method = "height"`` (and
    the pairs' own labels, if any, not used) up to the association: method, note,
    object counts, median height of the objects; for US3D, the share of object pixels
    whose lidar disparity stands more than 2 px above the lidar's own ground (from
    :func:`ground_disparity`) against that share over the whole image, and the share of
    the built pixels (lidar-elevated and not green: green leaf index at most
    ``tree_greenness``) that an object covers, a recall, and the share of them in the
    regions each rule left out (:attr:`radcons.stages.objects.regions.HeightObjects.
    left_out`): where the recall is lost. Overlays (objects on the reference, height
    map) are written to ``--out``.

``heldout``
    Objects as ``radcons process`` finds them (the ``radcons`` preset, ``use_supplied =
    False``) on demo pairs of seeds no value was chosen on (``--split heldout``: 1000-1009;
    ``--split tuning``: 0-9), per scenario and size, and on the US3D tiles against their
    lidar, for each ground of ``--ground`` (``windows``, ``bulldozer``), with the objects
    stage's time; then where the figures fall short of the targets
    (:mod:`objects_bench.heldout`). Not among the sections run by default.
``ablation``
    What each rule of the height method buys: the figures of ``heldout`` (demo pairs of
    ``--split``, ``fresh`` (2000-2009) for this section, and the US3D tiles) with every
    rule on, then with each rule of ``--rules`` (all of
    :data:`objects_bench.ablation.RULES` by default) switched off in turn, and the
    differences. Not among the sections run by default.

``--set STAGE.KEY=VALUE`` (TOML values) changes the ``radcons`` preset the ``heldout`` and
``ablation`` sections run.

The sections are in the package ``objects_bench`` beside this script.

Run: ``nice .venv/bin/python benchmarks/bench_objects.py [--only demo timing ...]``;
``--only heldout --ground windows bulldozer`` for the held-out split; ``--only ablation
--split fresh --sizes 512`` for the rule ablation.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from objects_bench.ablation import RULES, ablation
from objects_bench.demo import demo, misses, trees
from objects_bench.heldout import SPLITS, heldout
from objects_bench.real import real
from objects_bench.timing import timing

SECTIONS = {
    "demo": demo, "misses": misses, "trees": trees, "timing": timing, "real": real, "heldout": heldout,
    "ablation": ablation,
}


def main() -> None:
    """Run the sections ``--only`` names (all but ``heldout`` and ``ablation`` by default)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=tuple(SECTIONS))
    parser.add_argument("--scenarios", nargs="+", default=["mixed", "multi-sensor", "multi-temporal"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--sizes", nargs="+", type=int, default=[512, 1024])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path("/tmp/bench_objects"))
    parser.add_argument("--split", choices=tuple(SPLITS), default="heldout", help="seeds of the heldout and ablation sections")
    parser.add_argument(
        "--ground", nargs="+", choices=("windows", "bulldozer"), default=["windows"],
        help="grounds the heldout section compares",
    )
    parser.add_argument(
        "--set", nargs="+", default=[], metavar="STAGE.KEY=VALUE", help="change the radcons preset (heldout, ablation)"
    )
    parser.add_argument("--rules", nargs="+", choices=tuple(RULES), metavar="RULE", help="rules the ablation switches off")
    args = parser.parse_args()
    sections = args.only or ["demo", "misses", "trees", "timing", "real"]
    for name, run in SECTIONS.items():
        if name in sections:
            run(args)


if __name__ == "__main__":
    main()
