"""Parameters of the objects stage, for both of its methods.

:class:`ObjectsParams` sets the image-only path (:mod:`radcons.stages.objects_mbi`, the
``paper`` preset's), the height method (:mod:`radcons.stages.objects_height` and the
searches it calls, the ``radcons`` preset's) and whether label rasters supplied with a
pair win. Each attribute says what it does, where its default was chosen and what it
measured there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from radcons.errors import ParamsError
from radcons.stages.objects_height import check_height_params
from radcons.validate import check_fields

__all__ = ["ObjectsParams"]

_POLARITIES = ("bright", "dark", "both")


@dataclass(frozen=True)
class ObjectsParams:
    """Parameters of object extraction.

    Attributes
    ----------
    min_size, max_size : int
        Shortest and longest extent, px, of a building along any direction (lengths of the
        linear structuring elements); 121 px is 60 m at 0.5 m resolution.
    min_area : int
        Smallest object kept, in pixels.
    min_contrast : float
        The MBI threshold is at least this many noise standard deviations.
    smooth_sigma : float
        Gaussian pre-smoothing, px (0 = none).
    polarity : str
        ``"bright"`` (roofs brighter than their surroundings), ``"dark"`` or ``"both"``.
    use_supplied : bool
        When the pair carries its own label rasters (building footprints), use them instead
        of segmenting (default). False always segments, e.g. to judge the segmentation
        against ground-truth labels.
    method : str
        ``"mbi"``: the image-only index above, each image on its own (the ``paper``
        preset); ``"height"``: objects standing above the ground in the pair's census
        disparity, moved into the target by their own disparity
        (:func:`height_objects`; the ``radcons`` preset). The parameters below are the
        height method's.
    census_cell_m : float
        Cell of the reduced grid the census disparity is computed on (m): the images are
        area-averaged by ``round(census_cell_m / gsd)`` (the pair's ground sample distance,
        from its metadata or its RPC models, else ``assumed_gsd_m``). A 20 m block is then
        20 cells wide, enough for a flat core to seed its region
        (:func:`radcons.stages.objects_height.segment_elevated`); at 2.5 m cells
        semi-global smoothing turns it into a ramp.
    census_side : int
        Largest side of that grid, px: a coarser grid where the cell would make it larger
        (time and memory on large images).
    search_share : float
        With no known disparity range, +/- this share of the image width is searched.
    min_valid_share : float
        Below this share of left-right consistent pixels the disparity has failed: the
        image-only method is used instead and the summary says why.
    ground_window_m : float
        Side of the ground windows (m): larger than the largest building.
    ground_percentile : float
        Percentile of a window's disparities taken as its ground.
    min_height_m, min_height_px : float
        Height above ground that makes a pixel elevated, in metres when the ground sample
        distance and base-to-height ratio are known, else in disparity pixels.
        ``min_height_px`` was set on US3D JAX_072 (lidar truth, no scale known: the
        pairs without RPC models or metadata are judged in pixels), JAX_122 held out:
        2.0 -> 1.5 takes in the row houses that stand 3.5 px above the ground, 0.17 ->
        0.24 of the built pixels (lidar-elevated, not green) covered by an object, the
        share of object pixels the lidar shows elevated 0.91 -> 0.88; JAX_122 0.26 ->
        0.30 and 1.00 -> 0.93 (``benchmarks/bench_objects.py --only real``). Ventoux
        keeps no object.
    split_jump_m, split_jump_px : float
        Height spread over a 3 x 3 census neighbourhood that separates two objects.
    min_area_m2, max_area_m2 : float
        Area range of an object (m²).
    assumed_gsd_m : float
        Ground sample distance taken for lengths and areas when neither the pair's metadata
        nor its RPC models give one (m).
    min_elevated_share : float
        Share of a snapped region that must be elevated for it to be an object.
    tree_texture, tree_rectangularity, tree_hull_rectangularity : float
        An object more textured than ``tree_texture`` times the image's median gradient,
        or less rectangular than ``tree_rectangularity`` with a convex hull less
        rectangular than ``tree_hull_rectangularity`` (round and ragged), is a tree (or
        no building) and is left out ...
    roof_rectangularity : float
        ... but a textured object at least this rectangular (area over its smallest
        rotated rectangle; small objects reach a little above 1) is a roof: small roofs
        with their furniture are as textured as crowns, and crowns are never rectangles
        (0..2; 2: texture alone decides, as before). Demo pairs, 512 px
        (``benchmarks/bench_objects.py --only demo --sizes 512``), seeds 0-4, where it
        was chosen: mean IoU 0.654 -> 0.663, recall at 0.5 0.753 -> 0.764; seeds 5-9,
        not used to choose: 0.675 -> 0.690, 0.741 -> 0.757; the share of objects that
        are buildings unchanged (0.723 -> 0.724, 0.733 -> 0.734). The missed-building
        search keeps its texture rule: rectangular rows of parked cars are textured
        too (exempting its segments lowered that share on seeds 5-9 to 0.707).
    census_cross_check : str
        Left-right check of the final census run (:class:`CensusParams` ``cross_check``).
    flat_edges : float
        Seeds are cut where the reference's gradient exceeds this many times its median
        (the edges between adjacent roofs); 0 keeps the height seeds whole.
    min_match_score : float
        An object whose mean census cost against the target (share of the descriptor's
        bits) at the ground's disparity under it exceeds the one at its D̄m by less is
        left out (its elevation is a disparity artefact: a roof matches best at its own
        disparity).
    min_object_height : float
        An object whose median height is lower than this many times the height threshold
        is left out (ground raised by a mismatch, cars, hedges).
    disparity_radius : int
        D̄m is refined within this many px of the census mode by the census cost of the
        object's pixels at full resolution; 0 keeps the mode.
    find_missed : bool
        Also look for the buildings the census grid misses (small ones): segments of the
        reference that no object covers, each matched over the whole disparity range as
        one census window, kept when they stand above the ground, match uniquely and are
        shaped like a roof (:mod:`radcons.stages.objects_missed`).
        ``benchmarks/bench_objects.py --only demo``, labels withheld, off -> on, seeds 0-4
        (where its values were chosen): 512 px mean IoU 0.615 -> 0.654, recall at 0.5
        0.709 -> 0.753, objects that are buildings 0.744 -> 0.723; 1024 px IoU 0.615 ->
        0.661, recall 0.646 -> 0.693, objects that are buildings 0.734 -> 0.717; seeds 5-9
        (not used to choose): 512 px IoU 0.602 -> 0.675, recall 0.658 -> 0.741, 0.743 ->
        0.733; 1024 px IoU 0.623 -> 0.667, recall 0.654 -> 0.706, 0.747 -> 0.749. About
        0.2 s more on a 1024 px pair.
    missed_scale : float
        Scale of the graph segmentation those segments come from (larger: larger
        segments), at about 0.75 m a pixel.
    missed_rectangularity : float
        Such a segment is kept only when its area is at least this share of its smallest
        rotated rectangle.
    missed_margin : float
        ... and every disparity more than 2 px from its least-cost one costs at least this
        much more (share of the census bits): a unique match.
    textured_roof_rectangularity : float
        ... and a segment more textured than ``tree_texture`` is still a roof when its
        area and its hull both fill at least this share of its smallest rotated rectangle
        and its edges follow two perpendicular directions (a small roof covered with
        furniture; :func:`radcons.stages.objects_missed.is_roof_shaped`; 0: off). Demo
        pairs, labels withheld (``benchmarks/bench_objects.py --only demo``), seeds 0-4,
        where it was chosen (0.9, 0.95, 0.98, 1.0; without the alignment condition
        objects that are buildings fell by 0.002 more at 512 px): 512 px mean IoU 0.705
        -> 0.720, recall at 0.5 0.777 -> 0.793, objects that are buildings 0.858 ->
        0.860, D̄m within 1 px 0.917 -> 0.915; 1024 px 0.740 -> 0.748, 0.779 -> 0.786,
        0.882 -> 0.878, 0.898 -> 0.899. Seeds 5-9 (held out) have no such roof and gain
        nothing: 512 px 0.736, 0.787 unchanged, 0.847 -> 0.843, 0.892 unchanged; 1024 px
        0.748, 0.779 unchanged, 0.868 -> 0.862, 0.883 -> 0.878.
    tree_greenness : float
        On an RGB pair, an object whose median green leaf index ``(2G - R - B) / (2G + R +
        B)`` exceeds this is a tree (:func:`radcons.stages.object_rules.green_objects`).
        US3D JAX_122, where the shape and texture rules keep about 20 crowns: the crowns'
        medians 0.05-0.16, the four roofs' -0.003-0.001; JAX_072 (downtown), every
        object -0.12-0.02. Pairs without colour are not concerned.
    shadow_texture : float
        An object darker than the image's median whose texture (as ``tree_texture``)
        is below this is a shadow and is left out
        (:func:`radcons.stages.object_rules.is_shadow`): semi-global matching fills a
        region without texture from its neighbours, so a building's shadow takes the
        roof's disparity (0: off). Demo pairs, labels withheld
        (``benchmarks/bench_objects.py --only demo``), 512 px, seeds 0-4, where it was
        chosen: the textureless objects (below 0.3) were all dark and none a building,
        and 7 of their 8 D̄m were wrong; objects that are buildings 0.733 -> 0.759, D̄m
        within 1 px 0.843 -> 0.861, IoU and recall unchanged; seeds 5-9: 0.748 -> 0.754,
        0.827 -> 0.834; 1024 px, seeds 0-4: 0.788 -> 0.809, 0.851 -> 0.863.
    dark_brightness, dark_height : float
        An object darker than ``dark_brightness`` times the image's median grey level
        (``brightness`` of :func:`radcons.stages.object_features.object_features`) that
        stands lower than ``dark_height`` times the height threshold at its median is
        crowns or a shadow and is left out, counted with the trees
        (:func:`radcons.stages.object_rules.is_dark_and_low`; ``dark_height`` 0: off).
        Semi-global matching raises a dark patch beside a roof, or a group of crowns
        in the shade, part of the way to the roof beside it: it stands a few metres
        high, lower than a roof, and the texture of leaves or the edges of a shadow
        keep it past the texture and shadow rules. Demo pairs, labels withheld
        (``benchmarks/bench_objects.py --only demo``), seeds 0-4, where it was chosen
        (at 512 px the objects that are no building had a median brightness 0.61 and
        height 4.8 m, those that are a building 1.92 and 11.6 m; 0.8 or 1.0 with
        2.5 lose buildings): objects that are buildings 512 px 0.785 -> 0.836, 1024
        px 0.832 -> 0.868; D̄m within 1 px 0.882 -> 0.907 and 0.877 -> 0.904; IoU and
        recall unchanged. Seeds 5-9 (held out): 0.778 -> 0.815 and 0.835 -> 0.857;
        0.844 -> 0.876 and 0.874 -> 0.885; IoU and recall unchanged. US3D JAX_072:
        the two groves the other rules kept are left out.
    crown_alignment, crown_rectangularity, crown_height : float
        An object whose edges follow two perpendicular directions less than
        ``crown_alignment`` (``alignment`` of
        :func:`radcons.stages.object_features.object_features`), that fills less than
        ``crown_rectangularity`` of its smallest rotated rectangle and that stands lower
        than ``crown_height`` times the height threshold at its median is crowns, and is
        left out, counted with the trees (:func:`radcons.stages.object_rules.is_low_crown`;
        ``crown_alignment`` 0: off). Crowns along a road or beside a shadow have a few
        straight edges (alignment 0.15-0.4, above ``tree_alignment``), and a group of
        smooth crowns fills about pi / 4 of its rectangle (above ``tree_rectangularity``):
        on a panchromatic pair no other rule tells them from roofs. Chosen on the demo
        pairs' tuning seeds (0-4, 512 and 1024 px, the final objects' features:
        alignment 0.35-0.45, rectangularity 0.8-0.85 and 2.5-3 times the threshold
        remove no object that is a building and 3 to 5 that are none; the objects below
        0.4 and 0.8 that are buildings stand 4 or more times the threshold), then checked
        on US3D read as grey, without the colour rule: JAX_122 29 -> 18 objects, share of
        their pixels on buildings (lidar-elevated, not green) 0.37 -> 0.66, built pixels
        covered 0.30 -> 0.29; JAX_072 58 -> 55, 0.83 -> 0.84, 0.28 -> 0.25 (three houses
        lost: a hipped roof, whose ridges at 45 degrees cancel the outline's edges in
        ``alignment``, and two roofs whose outline spilled onto crowns and cars). Demo
        pairs, labels withheld (``benchmarks/bench_objects.py --only demo``): objects
        that are buildings 512 px 0.874 -> 0.887, 1024 px 0.879 -> 0.882; D̄m within 1 px
        0.932 -> 0.938 and 0.911 unchanged; mean IoU 0.713 -> 0.712 and 0.741 unchanged;
        recall unchanged. Seeds 5-9 (held out): 0.846 -> 0.854 and 0.870 -> 0.872, D̄m
        0.901 -> 0.910 and 0.880 -> 0.882, IoU and recall unchanged. Real pairs
        (``--only real``, colour rule on): JAX_072 56 -> 53 objects, lidar-elevated
        share 0.87 -> 0.88, built covered 0.28 -> 0.25; JAX_122 9 -> 7, 0.93 -> 0.98,
        0.30 -> 0.29; Gizeh 7 -> 5 (two ragged patches among the mastabas' ruins);
        Kahramanmaras pre1/pre2 78 -> 71 (ragged blobs over crowns and parts of
        several roofs); pre1/post1, Ventoux and Reunion unchanged.
    outline_edge : float
        An object whose outline no image edge follows (``outline`` of
        :func:`radcons.stages.object_features.object_features`: the median along its
        outline of the strongest gradient within 2 px, over the image's median
        gradient, below this) is a patch of ground raised by a mismatch and is left
        out, counted with the artefacts (:func:`radcons.stages.object_rules.is_edgeless`;
        0: off). On the real pairs the raised patches of a sports field (US3D JAX_072,
        outline 0.5-1.1), of a park (JAX_122, 1.7) and one of the two on the Great
        Pyramid's face (Gizeh, 1.6; the other, 2.0, stays) are left out, and no object
        the lidar shows elevated (3.5 and more); Kahramanmaras keeps all its objects
        (2.0 and more). Demo pairs, labels withheld (``benchmarks/bench_objects.py
        --only demo``), 1.5, 1.75, 2.0 and 2.5 tried on seeds 0-4: objects that are
        buildings 512 px 0.860 -> 0.874, 1024 px 0.878 -> 0.885; D̄m within 1 px 0.925 -> 0.932 and 0.909 -> 0.911; but IoU
        0.720 -> 0.713 and 0.748 -> 0.741, recall 0.793 -> 0.785 and 0.786 -> 0.779
        (a demo roof of low contrast has a weak outline; 2.0 loses 2.4 points of
        recall at 512 px). Seeds 5-9 (held out): buildings 0.843 -> 0.850 and 0.862
        -> 0.870, D̄m 0.897 -> 0.903 and 0.874 -> 0.880, IoU 0.736 -> 0.732 and 0.748
        -> 0.745, recall 0.787 -> 0.783 and 0.779 -> 0.776.
    tree_alignment : float
        An object whose edges (in it and at its outline) follow two perpendicular
        directions less than this (``alignment`` of
        :func:`radcons.stages.object_features.object_features`, 0..1) is a tree, a grove
        or no building (0: off). Demo pairs, labels withheld
        (``benchmarks/bench_objects.py --only demo``), seeds 0-4, where it was chosen
        (0.12-0.18 tried; 0.18 loses three buildings at 1024 px): objects that are
        buildings at 512 px 0.759 -> 0.785, D̄m within 1 px 0.861 -> 0.882; at 1024 px
        0.809 -> 0.832 and 0.863 -> 0.877; mean IoU and recall unchanged at both sizes.
    spilled_roof_texture : float
        A ragged object (``tree_rectangularity``, ``tree_hull_rectangularity``) is still
        no tree when it is at most this textured, its edges follow two perpendicular
        directions and it fills 0.45 of its smallest rotated rectangle, or its convex
        hull 0.8 of it: a roof whose region spilled onto its shadow, row houses set back
        from each other, or a hipped roof around a courtyard split at its corners into two
        L-shaped pairs of planes (:func:`radcons.stages.object_rules.is_spilled_roof`;
        0: off). Chosen on US3D JAX_072 (0.4-0.6, with alignments 0.4-0.6 tried; the
        rectangularity floor after JAX_122, where without it a ragged ground patch of
        0.40 became an object): objects 51 -> 56, share of their pixels the lidar shows
        elevated 0.88 -> 0.87, of the built pixels covered 0.24 -> 0.28
        (``benchmarks/bench_objects.py --only real``); Kahramanmaras pre1/pre2 75 -> 78
        (three parts of roofs); JAX_122, Gizeh, Kahramanmaras pre1/post1 and Ventoux
        unchanged. It does not help the demo pairs, whose roofs lost to the tree rule are
        textured (0.8-1.0): labels withheld, 512 px, seeds 0-4 unchanged, seeds 5-9
        objects that are buildings 0.850 -> 0.846, D̄m within 1 px 0.903 -> 0.901;
        1024 px, seeds 0-4 0.885 -> 0.879, seeds 5-9 unchanged. The hull floor came
        later, from the hipped roof of JAX_072 (hulls 0.83-0.84; the other smooth square
        objects the tree rule removes on the real pairs have 0.63-0.72): objects
        56 -> 57, built pixels covered 0.26 -> 0.28; no demo pair and no other real pair
        changed.
    tall_roof_height_m : float
        A textured object at least this high (m) that fills 0.7 of its smallest rotated
        rectangle, with a hull filling 0.8 of it and square edges, is no tree: the roof of
        an apartment block with its tanks and heaters
        (:func:`radcons.stages.object_rules.is_tall_roof`; applied where the height is in
        metres; 0: off). Chosen on the real pairs (``benchmarks/bench_objects.py --only
        real``), since no textured demo building is this high: the demo pairs' figures
        are unchanged, seeds 0-4 and 5-9, 512 and 1024 px. Objects on Kahramanmaras
        pre1/pre2 73 -> 88 and pre1/post1 49 -> 56, the added ones all roofs of blocks
        or a dome on the image (15 m: 91 and 58; 25 m: 85 and 53); Gizeh unchanged; the
        US3D pairs, whose heights are in pixels, untouched. 20 m rather than 15 m leaves
        out the tallest trees of a city (plane trees and oaks reach 20 m).
    cross_check_objects : bool
        Associate only the objects whose copy in the target, matched back into the
        reference over the searched range as one census window, finds its least cost
        within 2 px of D̄m (:func:`radcons.stages.object_disparity.matches_back`, an
        object-level left-right check). The others stay objects, without a D̄m, a
        target copy or a fit (``HeightObjects.unmatched``): dropping them (demo pairs,
        seeds 5-9, 512 px) took the IoU from 0.675 to 0.650, for 9 buildings lost of
        which 8 had a D̄m wrong by more than 1 px, and a search for a consistent D̄m
        over the whole range recovered none of them.
    join_roof_halves : bool
        Join two objects that are the planes of one gabled roof, split at its ridge by
        the snapping (:mod:`radcons.stages.roof_halves`). Demo pairs, labels withheld
        (``benchmarks/bench_objects.py --only demo``), seeds 0-4, where its thresholds
        were chosen: 1024 px mean IoU 0.702 -> 0.722, recall at 0.5 0.737 -> 0.773,
        objects that are buildings 0.715 -> 0.790; 512 px unchanged (0.663, 0.764).
        Seeds 5-9, not used to choose: 1024 px 0.713 -> 0.728, 0.750 -> 0.776, 0.747 ->
        0.803, D̄m within 1 px 0.837 -> 0.845; 512 px 0.691 -> 0.693, 0.759 -> 0.763.
    complete_gables : bool
        After every search for objects, grow an object that is one plane of a gabled
        roof (rectangular, its census disparity rising towards one side) by the other
        plane, found across that side: free pixels or another object that stand, match
        near its D̄m, and fall away from the ridge as the object rises to it
        (:mod:`radcons.stages.roof_mirror`). The shadow rule spares the grown roofs (a
        shaded plane darkens the whole roof's median). Demo pairs, labels withheld
        (``benchmarks/bench_objects.py --only demo``), seeds 0-4, where it was built:
        1024 px mean IoU 0.765 -> 0.767, recall at 0.5 0.805 -> 0.810, objects that are
        buildings 0.893 -> 0.899, D̄m within 1 px 0.916 -> 0.916; 512 px 0.739 -> 0.740,
        0.811 -> 0.816, 0.880 -> 0.886, 0.934 -> 0.934. Seeds 5-9 (held out): unchanged
        at both sizes (1024 px 0.764, 0.800, 0.897, 0.891; 512 px 0.747, 0.800, 0.869,
        0.909): it does not help there. Real pairs (``--only real``): one gabled roof of
        US3D JAX_072 whole instead of its sunlit plane; Kahramanmaras, Gizeh and the
        others unchanged. Without the symmetry test of
        :func:`radcons.stages.roof_mirror.complete_gables`' step 4, 512 px seeds 5-9 lost
        (recall 0.798, association precision 0.997): objects grew onto the ground beside
        them (one building 0.47 -> 0.32, three objects on no building), and on seeds 0-4
        three whole flat roofs did (0.96 -> 0.58, 0.91 -> 0.60, 0.73 -> 0.42). Without
        the rectangle test, three objects of Kahramanmaras that are no building (a grove,
        a strip along a road, part of a courtyard) grew onto the ground beside them;
        with it, 1024 px seeds 0-4 keep one building fewer (recall 0.812 -> 0.810).
    join_wings : bool
        After every search for objects, join two rectangular objects at one D̄m (within
        0.5 px) that touch across the width of the smaller (a wing on its block, the two
        ends of a roof cut by an edge inside it; :mod:`radcons.stages.roof_wings`),
        after a second pass of ``join_roof_halves`` for the objects the searches added.
        Two buildings of one height built wall to wall are joined too. Demo pairs,
        labels withheld (``benchmarks/bench_objects.py --only demo``), seeds 0-4, where
        it was built (both passes): 512 px mean IoU 0.673 -> 0.678, recall at 0.5 0.777
        -> 0.780, objects that are buildings 0.836 -> 0.856, D̄m within 1 px 0.907 ->
        0.905; 1024 px 0.723 -> 0.726, 0.773 -> 0.779, 0.868 -> 0.882, 0.904 -> 0.903.
        Seeds 5-9 (held out): 512 px 0.702 -> 0.704, 0.774 -> 0.774, 0.815 -> 0.827,
        0.876 -> 0.876; 1024 px 0.728 -> 0.730, 0.774 -> 0.779, 0.857 -> 0.866, 0.885
        -> 0.887. Joining only L and T shapes (the union less rectangular than 0.8)
        kept the gain at 512 px, seeds 0-4, but none of it elsewhere.
    find_in_removed : bool
        Look for roofs inside the elevated regions the rules removed (a roof whose region
        spilled onto its shadow or the crowns beside it is removed whole as a tree):
        fine segments of the reference verified by their own census disparity, joined
        when neighbouring at one disparity, kept when shaped like a roof
        (:mod:`radcons.stages.roof_parts`). Demo pairs, labels withheld, seeds 0-4, where
        it was built: 512 px mean IoU 0.662 -> 0.674, recall at 0.5 0.764 -> 0.777, objects
        that are buildings 0.733 -> 0.733, D̄m within 1 px 0.840 -> 0.843; seeds 5-9, not
        used to build it: 512 px 0.691 -> 0.702, 0.761 -> 0.774, 0.749 -> 0.748, D̄m 0.828
        -> 0.827; at 1024 px (seeds 0-4) 0.719 -> 0.723, 0.771 -> 0.773, 0.796 -> 0.788.
    find_clipped : bool
        Look for roofs clipped whole at full scale in one image (glare: the paper's Object
        1), which census cannot match inside: found by their outline and placed where the
        other image's edges follow it (:mod:`radcons.stages.clipped_roofs`). Demo pairs,
        labels withheld (``benchmarks/bench_objects.py --only demo``), off -> on, mean IoU /
        recall at 0.5 / objects that are buildings / D̄m within 1 px, with the other
        defaults as they are now; seeds 0-4, where it was built: 512 px 0.718 -> 0.739,
        0.790 -> 0.811, 0.880 -> 0.880, 0.938 -> 0.934; 1024 px 0.741 -> 0.765, 0.779 ->
        0.805, 0.879 -> 0.893, 0.914 -> 0.916; seeds 5-9, held out: 512 px 0.738 -> 0.747,
        0.789 -> 0.800, 0.853 -> 0.869, 0.904 -> 0.909; 1024 px 0.749 -> 0.764, 0.783 ->
        0.800, 0.884 -> 0.897, 0.889 -> 0.891. The US3D
        tiles and the Pleiades pairs keep their objects (no plateau there is clipped whole).
    removed_scale : float
        Felzenszwalb scale of those fine segments (:func:`radcons.stages.objects_missed.
        reference_segments`; 30 and 80 gave 512 px IoU 0.664 and 0.676 against 0.674).
    shadow_trim : float
        After the searches and the joins, each object loses its pixels darker than this
        share of its own median grey level (the reference smoothed over 0.5 m) and keeps
        the largest part of the rest with the holes it encloses: the cast shadow a region
        spilled onto (:func:`radcons.stages.object_outlines.trim_shadows`; 0: off). A shadow cast onto a
        roof by a taller part of it, where it reaches the outline, is cut off too. Demo
        pairs, labels withheld (``benchmarks/bench_objects.py --only demo``), 512 px,
        seeds 0-4, where it was chosen (0.4, 0.5 and 0.6, before the last shadow rules or
        at the end, on the rim within 3 or 6 m or the whole object; refining D̄m again
        on the trimmed object changed nothing): mean IoU 0.678 -> 0.688, recall at 0.5
        0.780 -> 0.782, objects that are buildings 0.856 -> 0.859, D̄m within 1 px 0.905
        -> 0.914; 1024 px 0.726 -> 0.729, 0.779 -> 0.779, 0.882 -> 0.882, 0.903 -> 0.898.
        Seeds 5-9 (held out): 512 px 0.704 -> 0.712, 0.774 -> 0.783, 0.827 -> 0.832,
        0.876 -> 0.886; 1024 px 0.730 -> 0.732, 0.779 -> 0.779, 0.866 -> 0.868, 0.887 ->
        0.892.
    outline_band : float
        Then the pixels within this many px of each object's outline, inside or out, go
        to the side, object or ground, whose grey level beside them they are nearer
        (:func:`radcons.stages.object_outlines.snap_rims`; 0: off). In pixels, not
        metres: the outline's error is the segmentation's, a pixel or two at any
        resolution. Demo pairs, labels withheld, 512 px, seeds 0-4, where it was chosen
        (1, 1.5, 2 and 3 px; the local means over 2, 3 or 5 px rings and Gaussians of 2,
        4 or 8 px; a contrast of 0.05, 0.1 or 0.2; twice over; before the shadow cut, or
        on the regions before the rules, which lowered the IoU to 0.691): mean IoU 0.688
        -> 0.705, recall at 0.5 0.782 -> 0.777, objects that are buildings 0.859 ->
        0.858, D̄m within 1 px 0.914 -> 0.917; 1024 px 0.729 -> 0.740, 0.779 -> 0.779,
        0.882 -> 0.882, 0.898 -> 0.898 (with the band, rings and Gaussian in metres, twice
        as many px at 1024: IoU 0.734).
        Seeds 5-9 (held out): 512 px 0.712 -> 0.736, 0.783 -> 0.787, 0.832 -> 0.847,
        0.886 -> 0.892; 1024 px 0.732 -> 0.748, 0.779 -> 0.779, 0.868 -> 0.868, 0.892 ->
        0.883.
    """

    min_size: int = 5
    max_size: int = 121
    min_area: int = 60
    min_contrast: float = 4.0
    smooth_sigma: float = 1.0
    polarity: str = "bright"
    use_supplied: bool = True
    method: str = "mbi"
    census_cell_m: float = field(default=1.0, metadata={"range": (0.25, 5.0), "step": 0.25})
    census_side: int = 1024
    search_share: float = 0.25
    min_valid_share: float = 0.35
    ground_window_m: float = 120.0
    ground_percentile: float = 10.0
    min_height_m: float = 2.0
    min_height_px: float = 1.5
    split_jump_m: float = 4.0
    split_jump_px: float = 3.0
    min_area_m2: float = 50.0
    max_area_m2: float = 60000.0
    assumed_gsd_m: float = 0.5
    min_elevated_share: float = 0.5
    tree_texture: float = 1.3
    tree_rectangularity: float = 0.6
    tree_hull_rectangularity: float = 0.85
    roof_rectangularity: float = field(default=0.9, metadata={"range": (0.0, 2.0), "step": 0.01})
    census_cross_check: str = "accurate"
    flat_edges: float = 2.5
    min_match_score: float = field(default=0.03, metadata={"range": (-0.5, 0.5), "step": 0.01})
    min_object_height: float = 1.75
    disparity_radius: int = 3
    find_missed: bool = True
    missed_scale: float = 150.0
    missed_rectangularity: float = 0.85
    missed_margin: float = field(default=0.01, metadata={"range": (0.0, 0.2), "step": 0.005})
    textured_roof_rectangularity: float = field(default=0.95, metadata={"range": (0.0, 1.2), "step": 0.01})
    tree_greenness: float = field(default=0.04, metadata={"range": (-0.2, 0.5), "step": 0.01})
    shadow_texture: float = field(default=0.3, metadata={"range": (0.0, 1.0), "step": 0.01})
    dark_brightness: float = field(default=0.7, metadata={"range": (0.0, 1.5), "step": 0.01})
    dark_height: float = field(default=3.0, metadata={"range": (0.0, 10.0), "step": 0.1})
    outline_edge: float = field(default=1.75, metadata={"range": (0.0, 10.0), "step": 0.1})
    crown_alignment: float = field(default=0.4, metadata={"range": (0.0, 1.0), "step": 0.01})
    crown_rectangularity: float = field(default=0.8, metadata={"range": (0.0, 2.0), "step": 0.01})
    crown_height: float = field(default=3.0, metadata={"range": (0.0, 10.0), "step": 0.1})
    tree_alignment: float = field(default=0.15, metadata={"range": (0.0, 1.0), "step": 0.01})
    spilled_roof_texture: float = field(default=0.5, metadata={"range": (0.0, 2.0), "step": 0.05})
    tall_roof_height_m: float = field(default=20.0, metadata={"range": (0.0, 100.0), "step": 1.0})
    cross_check_objects: bool = True
    join_roof_halves: bool = True
    complete_gables: bool = True
    join_wings: bool = True
    find_in_removed: bool = True
    find_clipped: bool = True
    removed_scale: float = 50.0
    shadow_trim: float = field(default=0.5, metadata={"range": (0.0, 1.0), "step": 0.05})
    outline_band: float = field(default=2.0, metadata={"range": (0.0, 6.0), "step": 0.5})

    def __post_init__(self) -> None:
        check_fields(self, "objects")
        check_height_params(self)
        if self.min_area < 1:
            raise ParamsError(f"objects min_area must be >= 1, got {self.min_area}")
        if not 1 <= self.min_size < self.max_size:
            raise ParamsError(
                f"objects sizes need 1 <= min_size < max_size, got {self.min_size}, {self.max_size}"
            )
        if self.min_contrast < 0:
            raise ParamsError(f"objects min_contrast must be >= 0, got {self.min_contrast}")
        if self.smooth_sigma < 0:
            raise ParamsError(f"objects smooth_sigma must be >= 0, got {self.smooth_sigma}")
        if self.polarity not in _POLARITIES:
            raise ParamsError(f"objects polarity must be one of {_POLARITIES}, got {self.polarity!r}")
