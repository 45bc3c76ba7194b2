"""Object (building) extraction from one image (section 3).

The paper segments buildings with Shu et al.'s non-negative low-rank sparse correlation
mapping, which has no public implementation. radcons uses a morphological building index
(MBI, Huang and Zhang 2012) instead: it is made for building roofs on high-resolution
urban imagery, needs no training, and costs a few OpenCV morphological operations:

1. invalid pixels are filled with the nearest valid value and the image is smoothed with
   a small Gaussian (``smooth_sigma``) so single noisy pixels do not form structures;
2. for each of four directions (0, 45, 90, 135 degrees) the white top-hat with a linear
   structuring element of length ``max_size`` minus the one of length ``min_size`` keeps
   the bright structures shorter than ``max_size`` and wider than ``min_size`` along that
   direction; the MBI is the mean over the directions (roofs are short in every
   direction and score in all four, roads in three at most). With plain openings the
   top-hat grows monotonically with the length, so Huang and Zhang's sum of differential
   profiles over all lengths reduces to these two lengths; plain openings replace their
   openings by reconstruction, which cost about 0.4 s per 1024 x 1024 call;
3. the MBI is thresholded at the larger of Otsu's threshold and ``min_contrast`` times the
   image's noise level (Donoho's robust estimator), so an image with nothing standing out
   of its noise yields no objects;
4. the mask is cleaned (opening with a 3 x 3 square, holes filled), split into
   8-connected components, and components smaller than ``min_area`` pixels are dropped.

``polarity = "dark"`` runs the same on the inverted image (dark roofs); ``"both"`` joins
the two masks. The MBI misses roofs no brighter than their surroundings.

A graph segmentation (Felzenszwalb and Huttenlocher 2004, scikit-image) was measured as
an alternative on the demo pairs: it also finds roofs no brighter than their
surroundings, but it cuts the ground into hundreds of objects, splits uniform roofs into
pieces on simple scenes and is several times slower, so it was not kept.

References
----------
Huang, X., Zhang, L. (2012). Morphological building/shadow index for building extraction
from high-resolution imagery over urban areas. IEEE JSTARS 5(1), 161-172.
Otsu, N. (1979). A threshold selection method from gray-level histograms. IEEE SMC 9(1).
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import cv2
import numpy as np
import scipy.ndimage
from skimage.filters import threshold_otsu

from radcons.census import CensusParams
from radcons.errors import InputError, ParamsError, StageError
from radcons.noise import noise_sigma
from radcons.stages.height import (
    HeightMap,
    census_factor,
    coarse_disparity,
    downsample,
    fill_occlusions,
    ground_disparity,
    height_above_ground,
)
from radcons.stages.clipped_roofs import clipped_roofs, mostly_on
from radcons.stages.object_disparity import census_descriptors
from radcons.stages.object_features import ImageScales, object_features
from radcons.stages.object_outlines import snap_rims, trim_shadows
from radcons.stages.object_rules import green_objects, is_dark_and_low, is_edgeless, is_low_crown, is_shadow, is_tree
from radcons.stages.objects_height import (
    HeightObjects,
    check_height_params,
    keep_objects,
    match_scores,
    matched_back,
    object_disparities,
    refined_disparities,
    relabel,
    segment_elevated,
    transfer_to_target,
)
from radcons.stages.objects_missed import MAX_PIXELS, missed_objects, reference_segments
from radcons.stages.roof_halves import join_roof_halves
from radcons.stages.roof_parts import roofs_in_removed
from radcons.stages.roof_wings import join_wings
from radcons.validate import check_fields, single_band_image

__all__ = ["ObjectsParams", "building_index", "extract_objects", "height_objects"]

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
        directions and it fills 0.45 of its smallest rotated rectangle: a roof whose
        region spilled onto its shadow, or row houses set back from each other
        (:func:`radcons.stages.object_rules.is_spilled_roof`; 0: off). Chosen on US3D
        JAX_072 (0.4-0.6, with alignments 0.4-0.6 tried; the rectangularity floor after
        JAX_122, where without it a ragged ground patch of 0.40 became an object):
        objects 51 -> 56, share of their pixels the lidar shows elevated 0.88 -> 0.87,
        of the built pixels covered 0.24 -> 0.28 (``benchmarks/bench_objects.py --only
        real``); Kahramanmaras pre1/pre2 75 -> 78 (three parts of roofs); JAX_122, Gizeh,
        Kahramanmaras pre1/post1 and Ventoux unchanged. It does not help the demo pairs,
        whose roofs lost to the tree rule are textured (0.8-1.0): labels withheld, 512 px,
        seeds 0-4 unchanged, seeds 5-9 objects that are buildings 0.850 -> 0.846, D̄m
        within 1 px 0.903 -> 0.901; 1024 px, seeds 0-4 0.885 -> 0.879, seeds 5-9
        unchanged.
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
    cross_check_objects: bool = True
    join_roof_halves: bool = True
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


def _line(length: int, angle: int) -> np.ndarray:
    """Linear structuring element of ``length`` pixels at 0, 45, 90 or 135 degrees."""
    if angle == 0:
        return np.ones((1, length), np.uint8)
    if angle == 90:
        return np.ones((length, 1), np.uint8)
    diagonal = np.eye(length, dtype=np.uint8)
    return diagonal[::-1] if angle == 45 else diagonal


def building_index(image: np.ndarray, params: ObjectsParams = ObjectsParams()) -> np.ndarray:
    """Morphological building index of a finite image (bright structures).

    The openings run on the image quantised to 16 bits over its own range (OpenCV's
    morphology is about twice as fast on uint16 as on float32); the index is returned in
    the image's grey levels.

    Parameters
    ----------
    image : ndarray, shape (M, N), float32
        Finite image (invalid pixels already filled).
    params : ObjectsParams

    Returns
    -------
    ndarray, shape (M, N), float32
        ``mean_d [tophat(d, max_size) - tophat(d, min_size)]``, >= 0, in grey levels.
    """
    low, high = float(image.min()), float(image.max())
    if high <= low:
        return np.zeros(image.shape, np.float32)
    step = (high - low) / 65535.0
    quantised = np.rint((image - np.float32(low)) * np.float32(1.0 / step)).astype(np.uint16)
    total = np.zeros(image.shape, np.int32)
    for angle in (0, 45, 90, 135):
        total += cv2.morphologyEx(quantised, cv2.MORPH_OPEN, _line(params.min_size, angle))
        total -= cv2.morphologyEx(quantised, cv2.MORPH_OPEN, _line(params.max_size, angle))
    return total.astype(np.float32) * np.float32(step / 4.0)


def _mask(index: np.ndarray, valid: np.ndarray, floor: float) -> np.ndarray:
    """``index > max(Otsu threshold, floor)`` on valid pixels (Otsu on a 1024-bin histogram)."""
    values = index[valid]
    top = float(values.max(initial=0.0))
    if top <= floor:
        return np.zeros(index.shape, bool)
    bins = np.minimum((values * np.float32(1023.0 / top)).astype(np.int32), 1023)
    counts = np.bincount(bins, minlength=1024)
    centres = (np.arange(1024) + 0.5) * (top / 1023.0)
    threshold = max(float(threshold_otsu(hist=(counts, centres))), floor)
    return (index > threshold) & valid


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """Fill the background areas not connected (4-neighbours) to the image border."""
    outside = np.pad(~mask, 1, constant_values=True).astype(np.uint8)
    cv2.floodFill(outside, None, (0, 0), 2)
    return outside[1:-1, 1:-1] != 2


def _mbi_objects(image: np.ndarray, valid: np.ndarray, floor: float, params: ObjectsParams) -> np.ndarray:
    if params.smooth_sigma > 0:
        image = cv2.GaussianBlur(image, (0, 0), params.smooth_sigma, borderType=cv2.BORDER_REFLECT)
    mask = np.zeros(image.shape, bool)
    if params.polarity in ("bright", "both"):
        mask |= _mask(building_index(image, params), valid, floor)
    if params.polarity in ("dark", "both"):
        mask |= _mask(building_index(-image, params), valid, floor)
    mask = cv2.morphologyEx(mask.view(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    mask = _fill_holes(mask) & valid
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    return relabel(labels, stats[:, cv2.CC_STAT_AREA] >= params.min_area)


def extract_objects(image: np.ndarray, params: ObjectsParams = ObjectsParams()) -> np.ndarray:
    """Segment the buildings of an image into labelled objects.

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Single-band image, NaN where invalid (any real dtype; computed in float32).
    params : ObjectsParams

    Returns
    -------
    ndarray, shape (M, N), int32
        0 = background (and invalid pixels), 1..K the objects.

    Raises
    ------
    InputError
        Not 2-D, empty, not real numbers, or no valid pixel.
    """
    image = single_band_image(image, "image", 1, "is empty")
    valid = np.isfinite(image)
    floor = params.min_contrast * noise_sigma(image)
    if not valid.all():
        nearest = scipy.ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        image = image[tuple(nearest)]
    return _mbi_objects(image, valid, floor, params)


#: Smallest side of a pair the height method matches (the range-finding run halves it
#: twice more than the census grid, and census needs its 5 x 5 window).
_MIN_SIDE = 32
#: Scale (m) of the gradient the tree rule's texture is measured with, and of the smoothing
#: of both images before an object is matched into the target.
_TEXTURE_SCALE_M = 0.5


def height_objects(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams = ObjectsParams(method="height"),
    *,
    gsd_m: float | None = None,
    base_to_height: float | None = None,
    disparity_range: tuple[float, float] | None = None,
    px_per_m: float | None = None,
    greenness: np.ndarray | None = None,
) -> HeightObjects:
    """Objects of both images from the pair's height above ground (the ``"height"`` method).

    See :mod:`radcons.stages.height` (disparity, ground, height) and
    :mod:`radcons.stages.objects_height` (regions, snapping, trees, transfer).

    Parameters
    ----------
    reference, target : ndarray
        The working (rectified) pair, NaN where invalid.
    params : ObjectsParams
    gsd_m, base_to_height : float, optional
        Ground sample distance (m) and base-to-height ratio; with both, heights are in
        metres.
    disparity_range : tuple of float, optional
        Known disparity range (px); else it is searched.
    px_per_m : float, optional
        Disparity pixels per metre of height when known otherwise (e.g. from the RPC
        models of an RPC rectification); wins over ``base_to_height / gsd_m``.
    greenness : ndarray, optional
        Green leaf index of the reference's pixels (an RGB reference,
        :attr:`radcons.io.Raster.greenness`): green objects are trees.

    Returns
    -------
    HeightObjects
        Empty labels and a note for a flat scene; the image-only objects (``method =
        "mbi"``) and the reason in ``note`` when the disparity fails on most of the image.

    Raises
    ------
    InputError
        Images not 2-D, of different shapes or without a valid pixel.
    """
    reference = single_band_image(reference, "reference", 1, "is empty")
    target = single_band_image(target, "target", 1, "is empty")
    if reference.shape != target.shape:
        raise InputError(f"height objects need a rectified pair of one shape, got {reference.shape} and {target.shape}")
    if greenness is not None and np.shape(greenness) != reference.shape:
        raise InputError(f"the greenness map's shape {np.shape(greenness)} differs from the reference's {reference.shape}")
    if min(reference.shape) < _MIN_SIDE:
        return _fallback(reference, target, params, f"the pair is too small for a census disparity ({_MIN_SIDE} px a side)")
    gsd = gsd_m if gsd_m and gsd_m > 0 else params.assumed_gsd_m
    sigma = max(1.0, _TEXTURE_SCALE_M / gsd)
    work = _ImageWork.start(reference, target, gsd, sigma, params)
    factor = census_factor(reference.shape, params.census_cell_m / gsd, params.census_side)
    census = CensusParams(cross_check=params.census_cross_check)
    try:
        disparity, searched, valid_share, factor = coarse_disparity(
            reference, target, factor, params.search_share, census, disparity_range
        )
    except (StageError, ParamsError) as error:
        return _fallback(reference, target, params, f"census matching failed ({error})")
    if valid_share < params.min_valid_share:
        return _fallback(
            reference, target, params,
            f"the census disparity is consistent on {100 * valid_share:.1f} % of the images' overlap "
            f"(min_valid_share {100 * params.min_valid_share:.0f} %)",
        )
    disparity = fill_occlusions(disparity)
    disparity[~np.isfinite(downsample(reference, factor)[: disparity.shape[0], : disparity.shape[1]])] = np.nan
    window = int(round(params.ground_window_m / gsd / factor))
    if not (px_per_m and px_per_m > 0) and gsd_m and base_to_height and gsd_m > 0 and base_to_height > 0:
        px_per_m = base_to_height / gsd_m
    metric = bool(px_per_m and px_per_m > 0)
    threshold = params.min_height_m if metric else params.min_height_px
    jump = params.split_jump_m if metric else params.split_jump_px
    ground = ground_disparity(disparity, window, params.ground_percentile, threshold * (px_per_m if metric else 1.0))
    height, unit, px_per_unit = height_above_ground(disparity, ground, px_per_m if metric else None)
    heights = HeightMap(disparity, ground, height, unit, px_per_unit, factor, searched, valid_share)
    empty = np.zeros(reference.shape, np.int32)
    if not (np.nan_to_num(height, nan=0.0) > threshold).any():
        note = f"no pixel stands {threshold:g} {unit} above the ground: a flat scene, no objects"
        return HeightObjects(empty, empty.copy(), "segmented", heights, "height", note)
    area = (params.min_area_m2 / gsd**2, params.max_area_m2 / gsd**2)
    labels = segment_elevated(reference, heights, threshold, jump, area, params.min_elevated_share, params.flat_edges)
    scales = work.scales()
    features = object_features(reference, labels, heights, sigma, scales)
    trees, low = np.zeros(int(labels.max()) + 1, bool), np.zeros(int(labels.max()) + 1, bool)
    for index, feature in features.items():
        trees[index] = is_tree(feature, params)
        low[index] = not feature["height"] >= params.min_object_height * threshold
    census = work.census()
    found = object_disparities(reference, target, labels, heights, sigma, params.disparity_radius, census)
    keep = np.zeros(trees.size, bool)
    for index, (_, _, contrast) in found.items():
        keep[index] = not trees[index] and not low[index] and not np.nan_to_num(contrast) < params.min_match_score
    mismatched = int(sum(1 for i in found if not trees[i] and not keep[i]))
    removed = (labels > 0) & ~keep[labels]
    rule = np.select([keep, trees, low], [0, 1, 2], 3).astype(np.uint8)  # LEFT_OUT_RULES
    left_out = np.where(removed, rule[labels], 0).astype(np.uint8)
    modal = {i: values[0] for i, values in found.items()}
    scores = {i: values[1] for i, values in found.items()}
    labels, modal, scores = keep_objects(labels, keep, modal, scores)
    if params.join_roof_halves:
        labels, modal, scores = join_roof_halves(labels, modal, scores)
    clipped = np.zeros(reference.shape, bool)
    if params.find_clipped:
        lowest = params.min_object_height * threshold * heights.px_per_unit
        (labels, modal, scores), clipped = _with_clipped_roofs(
            (labels, modal, scores), (reference, target), heights, lowest, area, sigma
        )
    if params.find_missed:
        missed = missed_objects(
            reference, labels, heights, census, params, gsd, threshold, scales, work.segments(params.missed_scale)
        )
        labels, modal, scores = _with_new_objects((labels, modal, scores), missed, (reference, target), sigma)
    if params.find_in_removed:
        roofs = roofs_in_removed(
            reference, labels, removed, heights, census, params, gsd, threshold, scales,
            work.segments(params.removed_scale),
        )
        labels, modal, scores = _with_new_objects((labels, modal, scores), roofs, (reference, target), sigma)
    if params.join_roof_halves and (params.find_missed or params.find_in_removed):
        labels, modal, scores = join_roof_halves(labels, modal, scores)
    if params.join_wings:
        labels, modal, scores = join_wings(labels, modal, scores)
    labels = snap_rims(trim_shadows(labels, scales.smooth, params.shadow_trim), reference, params.outline_band)
    crowns = 0
    if labels.any():
        shadow = np.zeros(int(labels.max()) + 1, bool)
        edgeless = np.zeros(int(labels.max()) + 1, bool)
        dark = np.zeros(int(labels.max()) + 1, bool)
        low_crown = np.zeros(int(labels.max()) + 1, bool)
        for index, feature in object_features(reference, labels, heights, sigma, scales).items():
            shadow[index] = is_shadow(feature, params)
            edgeless[index] = is_edgeless(feature, params)
            dark[index] = is_dark_and_low(feature, params, threshold)
            low_crown[index] = is_low_crown(feature, params, threshold)
        shade = shadow | edgeless
        dark &= ~shade
        low_crown &= ~(shade | dark)
        mismatched += int(shade.sum())
        crowns = int(dark.sum() + low_crown.sum())
        rule = np.select([shadow, edgeless, dark, low_crown], [4, 5, 6, 8], 0).astype(np.uint8)
        left_out = np.where(labels > 0, rule[labels], left_out).astype(np.uint8)
        labels, modal, scores = keep_objects(labels, ~(shade | dark | low_crown), modal, scores)
    green = 0
    if greenness is not None and labels.any():
        trees_by_colour = green_objects(labels, greenness, params.tree_greenness)
        green = int(trees_by_colour.sum())
        left_out[(labels > 0) & trees_by_colour[labels]] = 7
        labels, modal, scores = keep_objects(labels, ~trees_by_colour, modal, scores)
    left_out[labels > 0] = 0
    # a clipped roof's D̄m comes from its outline: census sees nothing inside it
    by_outline = set(np.nonzero(mostly_on(labels, clipped))[0].tolist())
    by_census = {i: shift for i, shift in modal.items() if i not in by_outline}
    modal = {**modal, **refined_disparities(labels, by_census, census, params.disparity_radius)}
    unmatched: tuple[int, ...] = ()
    if params.cross_check_objects and by_census:
        back = matched_back(labels, by_census, census, heights.searched_disparities(), MAX_PIXELS)
        unmatched = tuple(sorted(i for i, held in back.items() if not held))
        modal = {i: shift for i, shift in modal.items() if i not in unmatched}
    note = "" if labels.any() else f"no elevated region of {params.min_area_m2:g} m² or more that is not a tree"
    return HeightObjects(
        labels, transfer_to_target(labels, modal), "segmented", heights, "height", note, modal, scores,
        int(trees.sum()) + crowns + green, mismatched, unmatched, left_out, tuple(sorted(by_outline)),
    )


@dataclass(frozen=True)
class _ImageWork:
    """What the height method needs of the images alone, computed beside the census matching.

    The census descriptors of both images, the reference's gradient scales at 0.5 m
    (:class:`radcons.stages.object_features.ImageScales`) and its graph segments
    (:func:`radcons.stages.objects_missed.reference_segments`, at the scales of the
    searches switched on) do not depend on the disparity. They are computed in a worker
    thread while Pandora matches: both release the GIL for most of their work, and so
    does Pandora's C++ (0.23 s of 1.5 s at 1024 x 1024 px, `benchmarks/bench_objects.py
    --only timing`). A pair that falls back or is flat leaves its jobs to finish unused.
    """

    scales_job: Future
    descriptor_jobs: tuple[Future, Future]
    segment_jobs: dict[float, Future]

    @classmethod
    def start(
        cls, reference: np.ndarray, target: np.ndarray, gsd: float, sigma: float, params: ObjectsParams
    ) -> "_ImageWork":
        """Submit one pair's jobs to the worker thread, in the order they are needed.

        ``sigma`` is the smoothing of the gradient scales, px.
        """
        searches = ((params.missed_scale, params.find_missed), (params.removed_scale, params.find_in_removed))
        scales = {scale for scale, used in searches if used}
        return cls(
            _WORKER.submit(ImageScales.of, reference, sigma),
            (_WORKER.submit(census_descriptors, reference), _WORKER.submit(census_descriptors, target)),
            {scale: _WORKER.submit(reference_segments, reference, gsd, scale) for scale in sorted(scales)},
        )

    def census(self) -> tuple[np.ndarray, np.ndarray]:
        """Census descriptors of the reference and the target (waits for them)."""
        return self.descriptor_jobs[0].result(), self.descriptor_jobs[1].result()

    def scales(self) -> ImageScales:
        """The reference's gradient scales at 0.5 m (waits for them)."""
        return self.scales_job.result()

    def segments(self, scale: float) -> np.ndarray:
        """The reference's graph segments at ``scale`` (waits for them)."""
        return self.segment_jobs[scale].result()


#: The worker thread of :class:`_ImageWork`, shared by every call (jobs queue in order;
#: the thread starts with the first job).
_WORKER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radcons-objects")


def _with_new_objects(
    objects: tuple[np.ndarray, dict[int, float], dict[int, float]],
    new: tuple[np.ndarray, dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    sigma: float,
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """Objects, D̄m and match scores with ``new`` objects (labels 1..K and their D̄m) numbered after the others."""
    labels, modal, scores = objects
    added, shifts = new
    offset = int(labels.max())
    modal = {**modal, **{offset + i: shift for i, shift in shifts.items()}}
    scores = {**scores, **{offset + i: score for i, score in match_scores(*images, added, shifts, sigma).items()}}
    return np.where(added > 0, added + offset, labels).astype(np.int32), modal, scores


def _with_clipped_roofs(
    objects: tuple[np.ndarray, dict[int, float], dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    heights: HeightMap,
    lowest: float,
    area: tuple[float, float],
    sigma: float,
) -> tuple[tuple[np.ndarray, dict[int, float], dict[int, float]], np.ndarray]:
    """The objects with the roofs clipped in either image (:func:`clipped_roofs`), and where those roofs lie.

    The objects lying mostly on a clipped roof (its furniture) give way to it; the others
    keep their pixels.
    """
    roofs, shifts = clipped_roofs(*images, heights, lowest, area)
    if not shifts:
        return objects, np.zeros(roofs.shape, bool)
    labels, modal, scores = objects
    labels, modal, scores = keep_objects(labels, ~mostly_on(labels, roofs > 0), modal, scores)
    roofs[labels > 0] = 0
    return _with_new_objects((labels, modal, scores), (roofs, shifts), images, sigma), roofs > 0


def _fallback(reference: np.ndarray, target: np.ndarray, params: ObjectsParams, reason: str) -> HeightObjects:
    """The image-only objects of both images, with the reason the height method was left."""
    return HeightObjects(
        extract_objects(reference, params),
        extract_objects(target, params),
        "segmented",
        None,
        "mbi",
        f"{reason}: image-only objects (mbi) instead",
    )
