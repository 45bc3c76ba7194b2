"""Which elevated regions and objects are no building: the height method's rules.

Each rule judges one object by its :func:`radcons.stages.objects.features.object_features`
(or, for :func:`green_objects`, by the colour of its pixels) and the
:class:`radcons.stages.objects.params.ObjectsParams` fields that set it.
:data:`LEFT_OUT_RULES` names the code each rule writes into
:attr:`radcons.stages.objects.regions.HeightObjects.left_out`, for the analyst tuning them.

On the first regions (:func:`radcons.stages.objects.run.height_objects`):

- **Trees** (:func:`is_tree`): trees stand as high as low buildings. An object is a tree
  when it is textured (median gradient inside it more than ``tree_texture`` times the
  image's median: a crown is a pattern of leaves and gaps, a roof a uniform surface) and
  less rectangular than ``roof_rectangularity`` (a small roof with its furniture is as
  textured as a crown, but a crown is never a rectangle); or ragged and round (area less
  than ``tree_rectangularity`` of its smallest rotated rectangle and convex hull less than
  ``tree_hull_rectangularity`` of it: crowns and groves are round, while a notched or
  U-shaped roof, or one the snapping cut short, keeps a rectangular hull); or when its
  edges follow no two perpendicular directions (``alignment`` below ``tree_alignment``: a
  roof's outline, its furniture and its shadow are straight and square, the edges of
  crowns turn every way). A ragged object that is smooth and square
  (:func:`is_spilled_roof`) is a roof that spilled onto its shadow, row houses set back
  from each other or a hipped roof split at its corners; where heights are in metres, a
  textured near-rectangle standing ``tall_roof_height_m`` or more (:func:`is_tall_roof`)
  is an apartment block's roof, higher than a city's trees.
- **Low regions and mismatches**: an object whose median height is below
  ``min_object_height`` times the height threshold, or that matches the target no better
  at its D̄m than at the ground's disparity (``min_match_score``,
  :func:`radcons.stages.objects.transfer.object_disparities`), is ground raised by a
  mismatch.

On the final objects, after the searches, joins and outline treatment:

- **Shadows** (:func:`is_shadow`): a dark object without texture is the shadow of the
  building beside it, raised by the matcher's smoothing.
- **Edgeless patches** (:func:`is_edgeless`): an object whose outline no image edge
  follows is a patch of lawn, field or a pyramid's face that the matcher raised.
- **Dark and low** (:func:`is_dark_and_low`): crowns in the shade, or a shadow raised part
  of the way to the roof beside it.
- **Low crowns** (:func:`is_low_crown`): a low object with edges every way and no
  rectangle, on pairs without colour.
- **Green** (:func:`green_objects`): on an RGB pair, an object whose median green leaf
  index exceeds ``tree_greenness`` (crowns that are neither textured nor ragged at the
  image's scale).
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage

__all__ = [
    "LEFT_OUT_RULES", "is_spilled_roof", "is_tree", "is_shadow", "is_edgeless", "is_dark_and_low", "is_low_crown",
    "green_objects", "SPILLED_ROOF_ALIGNMENT", "SPILLED_ROOF_RECTANGULARITY", "SPILLED_ROOF_HULL_RECTANGULARITY",
    "is_tall_roof", "TALL_ROOF_RECTANGULARITY", "TALL_ROOF_HULL_RECTANGULARITY",
]

#: Code of each rule that leaves an elevated region out (:attr:`radcons.stages.objects.regions.HeightObjects.left_out`)
#: -> what it says the region is, and the parameters that set it.
LEFT_OUT_RULES: dict[int, str] = {
    1: (
        "tree: textured, ragged or with edges every way (tree_texture, tree_rectangularity, tree_alignment, "
        "spilled_roof_texture, tall_roof_height_m)"
    ),
    2: "too low (min_object_height)",
    3: "no better matched at its height than on the ground (min_match_score)",
    4: "shadow: dark without texture (shadow_texture)",
    5: "no image edge along its outline (outline_edge)",
    6: "dark and low: crowns in the shade (dark_brightness, dark_height)",
    7: "green: vegetation by colour (tree_greenness)",
    8: "crowns: low, with edges every way and not rectangular (crown_alignment, crown_rectangularity, crown_height)",
}


#: Alignment (``alignment`` of :func:`radcons.stages.objects.features.object_features`) of a smooth ragged object's edges
#: that makes it roofs (:func:`is_spilled_roof`) ...
SPILLED_ROOF_ALIGNMENT = 0.5
#: ... when it fills at least this share of its smallest rotated rectangle ...
SPILLED_ROOF_RECTANGULARITY = 0.45
#: ... or when its convex hull fills at least this share of the rectangle: a roof in the
#: shape of an L or of a ring around a courtyard, whose arms are wide (a thin L of two
#: walls has a hull of about 0.6).
SPILLED_ROOF_HULL_RECTANGULARITY = 0.8
#: Share of its smallest rotated rectangle a textured object taller than
#: ``tall_roof_height_m`` fills to be a roof (:func:`is_tall_roof`; a group of round crowns
#: fills about pi / 4 of it, a roof with furniture cut short by the snapping 0.7-0.9) ...
TALL_ROOF_RECTANGULARITY = 0.7
#: ... and its convex hull (a crown's is round: under pi / 4).
TALL_ROOF_HULL_RECTANGULARITY = 0.8


def is_spilled_roof(feature: dict[str, float], params: object) -> bool:
    """A smooth object whose edges are square is roofs, however ragged its outline.

    The snapping lets a region spill from a roof onto the shadow beside it, or take in
    two row houses set back from each other: the outline is then ragged, but the object
    is as smooth as a roof (``texture`` at most ``spilled_roof_texture``; leaves make a
    crown textured), its edges follow two perpendicular directions (``alignment`` at
    least :data:`SPILLED_ROOF_ALIGNMENT`) and it still fills half of its smallest
    rotated rectangle (:data:`SPILLED_ROOF_RECTANGULARITY`). A hipped roof around a
    courtyard, split at its corners into two L-shaped pairs of planes, fills a third
    of its rectangle but its convex hull nearly all of it
    (:data:`SPILLED_ROOF_HULL_RECTANGULARITY`): it is roofs too.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features`.
    params : ObjectsParams
        ``spilled_roof_texture`` is used (0: no object is exempted).
    """
    return (
        params.spilled_roof_texture > 0
        and feature["texture"] <= params.spilled_roof_texture
        and feature["alignment"] >= SPILLED_ROOF_ALIGNMENT
        and (
            feature["rectangularity"] >= SPILLED_ROOF_RECTANGULARITY
            or feature["hull_rectangularity"] >= SPILLED_ROOF_HULL_RECTANGULARITY
        )
    )


def is_tall_roof(feature: dict[str, float], params: object) -> bool:
    """A textured object that stands higher than a city's trees and is nearly a rectangle is a roof.

    The roofs of apartment blocks carry water tanks, solar heaters and stair housings:
    they are as textured as crowns (``texture`` above ``tree_texture``), and the
    snapping cuts them short of a full rectangle, so :func:`is_tree` takes them for
    trees. Standing ``tall_roof_height_m`` or more above the ground, filling
    :data:`TALL_ROOF_RECTANGULARITY` of their smallest rotated rectangle with a hull
    filling :data:`TALL_ROOF_HULL_RECTANGULARITY` of it, and with square edges
    (``alignment`` at least ``tree_alignment``), they are roofs. Only heights in metres
    can be compared with a tree's: :func:`is_tree` applies the rule where the height map
    is metric.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features`, ``height``
        in metres.
    params : ObjectsParams
        ``tall_roof_height_m`` (0: off) and ``tree_alignment`` are used.
    """
    return (
        params.tall_roof_height_m > 0
        and feature["height"] >= params.tall_roof_height_m
        and feature["rectangularity"] >= TALL_ROOF_RECTANGULARITY
        and feature["hull_rectangularity"] >= TALL_ROOF_HULL_RECTANGULARITY
        and feature["alignment"] >= params.tree_alignment
    )


def is_tree(feature: dict[str, float], params: object, metric: bool = False) -> bool:
    """A textured object that is no rectangle, a ragged one with a round hull, or one whose edges turn every way, is a tree, a grove or no building.

    A ragged object that is smooth and square (:func:`is_spilled_roof`) is not ragged
    in this sense. Where heights are in metres, an object that stands higher than a
    city's trees and is nearly a rectangle (:func:`is_tall_roof`) is no tree.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features`.
    params : ObjectsParams
        ``tree_texture``, ``roof_rectangularity``, ``tree_rectangularity``,
        ``tree_hull_rectangularity``, ``tree_alignment``, ``spilled_roof_texture`` and
        ``tall_roof_height_m`` are used (an object without any gradient, whose alignment
        is NaN, is not judged by it).
    metric : bool
        The feature's ``height`` is in metres (else disparity pixels: no tall roof).
    """
    ragged = (
        feature["rectangularity"] < params.tree_rectangularity
        and feature["hull_rectangularity"] < params.tree_hull_rectangularity
        and not is_spilled_roof(feature, params)
    )
    textured = feature["texture"] > params.tree_texture and feature["rectangularity"] < params.roof_rectangularity
    tree = textured or ragged or feature["alignment"] < params.tree_alignment
    return tree and not (metric and is_tall_roof(feature, params))


def is_shadow(feature: dict[str, float], params: object) -> bool:
    """A dark object without texture of its own is a shadow, whatever its disparity says.

    Semi-global matching fills a region without texture from its neighbours, so the
    shadow a building casts takes the building's disparity and stands as high as its
    roof. An object darker than the image's median (``brightness`` below 1) and smoother
    than ``shadow_texture`` (the ``texture`` of :func:`radcons.stages.objects.features.object_features`) is such a
    shadow; a bright roof without texture keeps its place.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features`.
    params : ObjectsParams
        ``shadow_texture`` is used (0: no object is a shadow).
    """
    return feature["brightness"] < 1.0 and feature["texture"] < params.shadow_texture


def is_edgeless(feature: dict[str, float], params: object) -> bool:
    """No image edge bounds the object: a patch of ground raised by a mismatch, not a building.

    A roof ends at an edge of the image (roof against ground, wall or shadow), and the
    outline is snapped to it. Semi-global matching on a surface without texture (a
    lawn, a sports field, a pyramid's face) can raise a patch whose outline follows the
    matcher's streaks instead, across grass. An object whose ``outline`` (the median,
    along its outline, of the strongest gradient within
    :data:`radcons.stages.objects.features.OUTLINE_REACH` px, over
    the image's median gradient; :func:`radcons.stages.objects.features.object_features`) is below ``outline_edge`` is
    such a patch.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features`.
    params : ObjectsParams
        ``outline_edge`` is used (0: every object is bounded).
    """
    return feature["outline"] < params.outline_edge


def is_dark_and_low(feature: dict[str, float], params: object, threshold: float) -> bool:
    """A dark object that stands low is crowns in the shade or a shadow, raised part of the way by the matcher.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features` (``brightness`` and ``height``).
    params : ObjectsParams
        ``dark_brightness`` and ``dark_height`` are used (``dark_height`` 0: no object
        is judged so).
    threshold : float
        The height threshold, in the height map's unit.
    """
    return feature["brightness"] < params.dark_brightness and feature["height"] < params.dark_height * threshold


def is_low_crown(feature: dict[str, float], params: object, threshold: float) -> bool:
    """A low object whose edges turn every way and whose outline is no rectangle is crowns.

    A group of crowns that the texture and shape rules keep (smooth crowns fill about
    pi / 4 of their rectangle, above ``tree_rectangularity``) has edges in every
    direction, like a blob, but so has a roof whose outline spilled onto its shadow; the
    crowns stand lower. On panchromatic pairs, where colour cannot tell them, this is
    the rule that does.

    Parameters
    ----------
    feature : dict
        The object's :func:`radcons.stages.objects.features.object_features` (``alignment``, ``rectangularity`` and
        ``height``).
    params : ObjectsParams
        ``crown_alignment`` (0: no object is judged so), ``crown_rectangularity`` and
        ``crown_height`` are used.
    threshold : float
        The height threshold, in the height map's unit.
    """
    return (
        feature["alignment"] < params.crown_alignment
        and feature["rectangularity"] < params.crown_rectangularity
        and feature["height"] < params.crown_height * threshold
    )


def green_objects(labels: np.ndarray, greenness: np.ndarray, limit: float) -> np.ndarray:
    """Which objects are vegetation by colour: the median green leaf index over them exceeds ``limit``.

    Parameters
    ----------
    labels : ndarray of int
        Objects of the reference (0 = background).
    greenness : ndarray
        Green leaf index of the reference's pixels (:func:`radcons.io.bands.green_leaf_index`),
        NaN where unknown.
    limit : float
        Greenest median a roof may have.

    Returns
    -------
    ndarray of bool
        Indexed by object id (entry 0, the background, False); objects without a known
        pixel are not green.
    """
    green = np.zeros(int(labels.max()) + 1, bool)
    for index, box in enumerate(scipy.ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        values = greenness[box][labels[box] == index]
        values = values[np.isfinite(values)]
        green[index] = bool(values.size) and float(np.median(values)) > limit
    return green
