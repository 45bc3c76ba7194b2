"""The objects stage: the buildings of both images of the pair.

Its parameters are :class:`ObjectsParams` (:mod:`~radcons.stages.objects.params`), and
``method`` chooses between two paths. Label rasters supplied with a pair win over both
(``use_supplied``).

**The height method** (``method = "height"``, the ``radcons`` preset's;
:func:`radcons.stages.objects.run.height_objects`): a building is what stands above the
ground in the pair's own disparity. Its sub-modules, in the order they first run:

1. :mod:`~radcons.stages.objects.matching`: census matching of the working pair on a
   reduced grid (:class:`~radcons.stages.objects.matching.PairMatching`, kept while the
   thresholds are tuned), and the images' census descriptors, gradient scales and graph
   segments computed beside it.
2. :mod:`~radcons.stages.objects.ground`: the ground disparity under every cell (a low
   percentile in windows larger than a building, then local plane fits) and the height
   above it, in metres where the pair's geometry is known, else in disparity pixels
   (:class:`~radcons.stages.objects.ground.HeightMap`).
3. :mod:`~radcons.stages.objects.regions`: the elevated regions, seeded on the census grid
   and snapped to the reference's edges by a watershed
   (:class:`~radcons.stages.objects.regions.HeightObjects` is the stage's result).
4. :mod:`~radcons.stages.objects.features` and :mod:`~radcons.stages.objects.rules`: what
   is measured of each object (texture, brightness, rectangularity, edge alignment,
   outline edge, height) and the rules that say it is no building: trees, groves, low
   regions, and later shadows, raised patches of ground, crowns and green objects.
5. :mod:`~radcons.stages.objects.transfer` (with :mod:`~radcons.stages.objects.disparity`,
   an object matched as one census window): each object's D̄m, its census contrast to the
   ground (mismatches are left out), and at the end its D̄m refined on its final core, the
   object-level left-right check and the move into the target by D̄m.
6. :mod:`~radcons.stages.objects.searches` (with
   :mod:`~radcons.stages.objects.census_check`, the census rules a candidate passes):
   roofs the regions missed: clipped whole in one image
   (:mod:`~radcons.stages.objects.searches.clipped`), too small for the census grid
   (:mod:`~radcons.stages.objects.searches.missed`), inside a region a rule removed
   (:mod:`~radcons.stages.objects.searches.parts`).
7. :mod:`~radcons.stages.objects.outlines`: the final outlines, without the cast shadow a
   region spilled onto and with the rim snapped to the roof's edge (also applied to the
   candidate roofs of the last search).
8. :mod:`~radcons.stages.objects.joins`: roofs cut in parts joined again: the two planes
   of a gabled roof (:mod:`~radcons.stages.objects.joins.halves`), a plane whose twin was
   lost (:mod:`~radcons.stages.objects.joins.mirror`), rectangular parts of one flat roof
   (:mod:`~radcons.stages.objects.joins.wings`).

In detail, :mod:`~radcons.stages.objects.run` runs, in this order: matching, ground, regions, the tree,
height and contrast rules with each region's D̄m, the roof halves joined, the three
searches, the halves joined again, the gables completed, the wings joined, the outlines'
shadow cut and rim snap, the shadow, edge, dark, crown and colour rules, then the final
D̄m, the left-right check and the move into the target.

**The image-only path** (``method = "mbi"``, the ``paper`` preset's, and the height
method's fallback when the census disparity fails): :mod:`~radcons.stages.objects.mbi`,
the morphological building index of each image on its own (standing in for the paper's
segmentation, section 3).

:mod:`~radcons.stages.objects.step` is what the pipeline calls: the pair's own label
rasters, else the method the parameters name, with the pair's geometry and the census
matching the pipeline keeps.
"""

from radcons.stages.objects.params import ObjectsParams

__all__ = ["ObjectsParams"]
