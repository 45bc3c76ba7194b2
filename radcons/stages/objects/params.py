"""Parameters of the objects stage, for both of its methods."""

from __future__ import annotations

from dataclasses import dataclass

from radcons.errors import ParamsError
from radcons.param_spec import check_declared, param

__all__ = ["ObjectsParams"]


@dataclass(frozen=True)
class ObjectsParams:
    """Parameters of object extraction.

    They set whether label rasters supplied with a pair win, the image-only path
    (:mod:`radcons.stages.objects.mbi`, the ``paper`` preset's: ``min_size`` to
    ``polarity``) and the height method (:mod:`radcons.stages.objects.run`, the
    ``radcons`` preset's: ``census_cell_m`` onwards). Each field's help, unit and range
    are in its declaration.
    """

    min_size: int = param(
        5, "Shortest extent of a building along any direction (length of the short linear structuring element).",
        unit="px", range=(1, None), step=1,
    )
    max_size: int = param(
        121, "Longest extent of a building along any direction (121 px is 60 m at 0.5 m a pixel).",
        unit="px", range=(2, None), step=1,
    )
    min_area: int = param(
        60, "Smallest object the image-only index keeps.", unit="px", range=(1, None), step=1,
    )
    min_contrast: float = param(
        4.0, "Least threshold of the building index, in noise standard deviations.", range=(0.0, 100.0), step=0.5,
    )
    smooth_sigma: float = param(
        1.0, "Gaussian smoothing of the image before the building index (0: none).",
        unit="px", range=(0.0, None), step=0.5,
    )
    polarity: str = param(
        "bright", "Which roofs the building index looks for: brighter or darker than their surroundings, or both.",
        choices=("bright", "dark", "both"),
    )
    use_supplied: bool = param(
        True, "Take the label rasters supplied with a pair instead of segmenting (false: always segment).",
        basic=True,
    )
    method: str = param(
        "mbi",
        "How objects are found: the image-only building index of each image (mbi) or what stands above the ground "
        "in the pair's census disparity (height).",
        choices=("mbi", "height"), basic=True,
    )
    census_cell_m: float = param(
        1.0, "Cell of the reduced grid the census disparity is computed on.",
        unit="m", range=(0.05, 50.0), step=0.25, basic=True,
    )
    census_side: int = param(
        1024, "Largest side of the census grid: a coarser grid where the cell would make it larger.",
        unit="px", range=(32, 4096), step=64,
    )
    search_share: float = param(
        0.25, "Share of the image width searched either way when no disparity range is known.",
        range=(0.01, 1.0), step=0.01,
    )
    min_valid_share: float = param(
        0.35,
        "Least share of left-right consistent pixels; below it the disparity has failed and the image-only method "
        "is used.",
        range=(0.0, 1.0), step=0.01,
    )
    ground_window_m: float = param(
        120.0, "Side of the windows the ground is taken in, larger than the largest building.",
        unit="m", range=(10.0, 10_000.0), step=10.0, basic=True,
    )
    ground_percentile: float = param(
        10.0, "Percentile of a window's disparities taken as its ground.", unit="%", range=(0.0, 50.0), step=1.0,
    )
    ground: str = param(
        "windows",
        "How the ground under the census disparity is found: a low percentile in windows refined by local plane "
        "fits (windows), or CNES Bulldozer's drape cloth, objects up to a quarter of ground_window_m (bulldozer; "
        "pip install 'radcons[bulldozer]').",
        choices=("windows", "bulldozer"),
    )
    min_height_m: float = param(
        2.0, "Height above ground that makes a pixel elevated, where the pair's geometry gives heights in metres.",
        unit="m", range=(0.5, 1000.0), step=0.5, basic=True,
    )
    min_height_px: float = param(
        1.5, "Height above ground that makes a pixel elevated, in disparity pixels, where no geometry is known.",
        unit="px", range=(0.5, 1000.0), step=0.5, basic=True,
    )
    split_jump_m: float = param(
        4.0, "Height spread over a 3 x 3 census neighbourhood that separates two objects, in metres.",
        unit="m", range=(0.5, 1000.0), step=0.5, basic=True,
    )
    split_jump_px: float = param(
        3.0, "Height spread over a 3 x 3 census neighbourhood that separates two objects, in disparity pixels.",
        unit="px", range=(0.5, 1000.0), step=0.5,
    )
    min_area_m2: float = param(
        50.0, "Smallest object the height method keeps.", unit="m²", range=(5.0, 1_000_000.0), step=5.0, basic=True,
    )
    max_area_m2: float = param(
        60000.0, "Largest object the height method keeps.",
        unit="m²", range=(10.0, 100_000_000.0), step=10.0,
    )
    assumed_gsd_m: float = param(
        0.5, "Ground sample distance taken when neither the pair's metadata nor its RPC models give one.",
        unit="m", range=(0.05, 100.0), step=0.05, basic=True,
    )
    min_elevated_share: float = param(
        0.5, "Share of a snapped region that must be elevated for it to be an object.", range=(0.0, 1.0), step=0.05,
    )
    tree_texture: float = param(
        1.3,
        "An object more textured than this many times the image's median gradient, and not rectangular, is a tree.",
        range=(0.05, 100.0), step=0.05, basic=True,
    )
    tree_rectangularity: float = param(
        0.6,
        "An object filling less of its smallest rotated rectangle than this, with a round hull, is a tree.",
        range=(0.0, 1.0), step=0.01,
    )
    tree_hull_rectangularity: float = param(
        0.85,
        "The hull share of its smallest rotated rectangle below which a ragged object is round (a tree).",
        range=(0.0, 1.0), step=0.01,
    )
    roof_rectangularity: float = param(
        0.9,
        "A textured object filling at least this share of its smallest rotated rectangle is a roof, not a tree "
        "(2: texture alone decides).",
        range=(0.0, 2.0), step=0.01,
    )
    census_cross_check: str = param(
        "accurate", "Left-right check of the final census run (CensusParams.cross_check).",
        choices=("accurate", "fast", "none"),
    )
    flat_edges: float = param(
        2.5,
        "Seeds are cut where the reference's gradient exceeds this many times its median (0: seeds kept whole).",
        range=(0.0, 100.0), step=0.1,
    )
    min_match_score: float = param(
        0.03,
        "Least census cost an object saves at its own disparity against the ground's (share of the descriptor's "
        "bits); below it the object is a mismatch.",
        range=(-2.0, 2.0), step=0.01,
    )
    min_object_height: float = param(
        1.75, "An object whose median height is below this many times the height threshold is left out.",
        range=(0.05, 100.0), step=0.05,
    )
    disparity_radius: int = param(
        3, "D̄m is refined by census within this many px of the census mode (0: the mode is kept).",
        unit="px", range=(0, 16), step=1,
    )
    find_missed: bool = param(
        True, "Look for the small buildings the census grid misses, as reference segments matched on their own.",
    )
    missed_scale: float = param(
        150.0, "Scale of the graph segmentation the missed buildings are looked for in (larger: larger segments).",
        range=(10.0, 10_000.0), step=10.0,
    )
    missed_rectangularity: float = param(
        0.85, "Least share of its smallest rotated rectangle a missed building fills.", range=(0.0, 1.0), step=0.01,
    )
    missed_margin: float = param(
        0.01,
        "Least extra cost (share of the census bits) of every disparity more than 2 px from a segment's best one.",
        range=(0.0, 1.0), step=0.005,
    )
    textured_roof_rectangularity: float = param(
        0.95,
        "A textured segment whose area and hull fill this share of its smallest rotated rectangle, with square "
        "edges, is a furnished roof (0: off).",
        range=(0.0, 2.0), step=0.01,
    )
    tree_greenness: float = param(
        0.04, "On an RGB pair, an object whose median green leaf index exceeds this is a tree.",
        range=(-1.0, 1.0), step=0.01, basic=True,
    )
    shadow_texture: float = param(
        0.3, "An object darker than the image's median and less textured than this is a shadow (0: off).",
        range=(0.0, 2.0), step=0.01,
    )
    dark_brightness: float = param(
        0.7,
        "An object darker than this many times the image's median grey level that stands low is crowns or a shadow.",
        range=(0.0, 2.0), step=0.01,
    )
    dark_height: float = param(
        3.0, "A dark object (dark_brightness) lower than this many times the height threshold is left out (0: off).",
        range=(0.0, 100.0), step=0.1,
    )
    outline_edge: float = param(
        1.75,
        "An object whose outline's edge is weaker than this many times the image's median gradient is a raised "
        "patch of ground (0: off).",
        range=(0.0, 100.0), step=0.1,
    )
    crown_alignment: float = param(
        0.4, "A low object whose edges follow two perpendicular directions less than this is crowns (0: off).",
        range=(0.0, 1.0), step=0.01,
    )
    crown_rectangularity: float = param(
        0.8,
        "A low object with edges every way filling less than this share of its smallest rotated rectangle is crowns.",
        range=(0.0, 2.0), step=0.01,
    )
    crown_height: float = param(
        3.0, "Crowns (the rule of crown_alignment) stand lower than this many times the height threshold.",
        range=(0.0, 100.0), step=0.1,
    )
    tree_alignment: float = param(
        0.15, "An object whose edges follow two perpendicular directions less than this is a tree (0: off).",
        range=(0.0, 1.0), step=0.01,
    )
    spilled_roof_texture: float = param(
        0.5, "A ragged object at most this textured, with square edges, is roofs, not a tree (0: off).",
        range=(0.0, 2.0), step=0.05,
    )
    tall_roof_height_m: float = param(
        20.0,
        "A textured, nearly rectangular object at least this high is an apartment block's roof, not a tree (0: off).",
        unit="m", range=(0.0, 1000.0), step=1.0, basic=True,
    )
    cross_check_objects: bool = param(
        True, "Move into the target only the objects whose copy there matches back at their D̄m.",
    )
    join_roof_halves: bool = param(True, "Join two objects that are the planes of one gabled roof.")
    complete_gables: bool = param(
        True, "Grow an object that is one plane of a gabled roof by the other plane, across its ridge.",
    )
    join_wings: bool = param(True, "Join two rectangular objects at one D̄m that touch across the smaller's width.")
    find_in_removed: bool = param(True, "Look for roofs inside the elevated regions the rules removed.")
    find_clipped: bool = param(True, "Look for roofs clipped whole at full scale in one image (glare).")
    removed_scale: float = param(
        50.0, "Scale of the graph segmentation roofs are looked for in inside the removed regions.",
        range=(10.0, 10_000.0), step=10.0,
    )
    shadow_trim: float = param(
        0.5, "Each final object loses its pixels darker than this share of its median grey level (0: off).",
        range=(0.0, 1.0), step=0.05,
    )
    outline_band: float = param(
        2.0, "Pixels this close to an outline go to the side, object or ground, whose grey level they are nearer.",
        unit="px", range=(0.0, 20.0), step=0.5,
    )

    def __post_init__(self) -> None:
        check_declared(self, "objects")
        if not self.min_size < self.max_size:
            raise ParamsError(f"[objects] min_size ({self.min_size}) must be below max_size ({self.max_size})")
        if not self.max_area_m2 > self.min_area_m2:
            raise ParamsError(
                f"[objects] max_area_m2 ({self.max_area_m2}) must exceed min_area_m2 ({self.min_area_m2})"
            )
