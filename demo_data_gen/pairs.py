"""Synthetic urban stereo pairs with exact ground truth and controlled radiometric differences.

A city quarter of 256 m x 256 m (roads with markings, parcels, buildings 5-60 m tall with
flat or gabled roofs, trees, cars, textured ground) is rendered into two epipolar-rectified
views: a nadir reference and an oblique target whose disparity is ``(B + r h) / g`` pixels
(``B`` = 6.2 m ground offset, base-to-height ratio ``r`` = 0.25, ``g`` = 256 m / size),
i.e. about 12 px for the ground plus up to 30 px for a 60 m tower at 512 px. The image size
changes the resolution, not the city: one seed gives the same city at every size.

The target then differs from the reference as the scenario says (Su et al. 2018, Sec. 1:
"different temporal images are obtained at different illumination conditions ... different
sensor images have different noise levels"):

``none``
    Same date and sensor: only the viewing geometry and an independent noise draw differ.
``multi-temporal``
    Another date: another sun (shadow length and direction, roof facets), a global gain,
    offset and gamma, one over-exposed roof (a metal roof's glare, clipped at full scale;
    the paper's Object 1), and local changes (cars moved, a building added or demolished,
    trees cut or planted, lawns dug up) marked in ``change_mask``.
``multi-sensor``
    Same date, another sensor: 8-bit instead of 11-bit, read noise of 6 instead of 1 grey
    level (8-bit equivalent), a wider point spread (MTF).
``mixed``
    Both.

The reference image of a seed and size is the same in every scenario, and each scenario
draws its date and its sensor from the same streams, so ``mixed`` is exactly the
combination of the other two.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from radcons.errors import InputError
from radcons.io import Pair, Raster

from demo_data_gen.layout import city_layout, date_changes
from demo_data_gen.scene import Rect, Region, Scene
from demo_data_gen.lighting import Sun, cast_shadows, shade
from demo_data_gen.rasterize import Grid, Layers, make_textures, paint_ground, rasterize
from demo_data_gen.sensor import Radiometry, Sensor, acquire
from demo_data_gen.views import Facades, Stereo, disparity, render_target, target_columns, target_view, visible_in_target

__all__ = ["SCENARIOS", "generate"]

SCENARIOS = ("none", "multi-temporal", "multi-sensor", "mixed")

#: Side of the square scene covered by the reference image (m).
SCENE_EXTENT_M = 256.0
#: Ground offset between the views (m) and base-to-height ratio.
STEREO = Stereo(base=6.2, ratio=0.25)
#: Tallest surface the target view must be able to see past (m): buildings plus terrain.
MAX_HEIGHT_M = 65.0
#: Margin around the image where the city continues, so that shadows come in from outside (m).
PAD_M = 20.0
MIN_SIZE, MAX_SIZE = 64, 4096

#: Blur of the scene radiance before it is sampled by either view (px): the part of the
#: optics both sensors share; it also band-limits the scene so that the views, sampled at
#: different sub-pixel positions, agree under the ground-truth disparity.
SCENE_BLUR_PX = 0.8
REFERENCE_SENSOR = Sensor("sim-WorldView-2", bit_depth=11, noise_sigma=8.0, blur_sigma=0.4)
OTHER_SENSOR = Sensor("sim-QuickBird", bit_depth=8, noise_sigma=6.0, blur_sigma=1.2)
REFERENCE_DATE = "2011-10-09"
OTHER_DATE = "2007-11-11"
#: Brightness of the over-exposed roof before saturation (full scale = 1).
GLARE_LEVEL = 1.5

# independent random streams, so that one scenario's draws never shift another's
_LAYOUT, _TEXTURE, _REF_DATE, _TGT_DATE, _CHANGES, _REF_NOISE, _TGT_NOISE = range(7)


def generate(size: int = 512, seed: int = 0, scenario: str = "mixed") -> Pair:
    """Generate a synthetic urban stereo pair with ground truth.

    Parameters
    ----------
    size : int
        Side of the square images in pixels, 64..4096.
    seed : int
        Non-negative seed; the same seed gives identical arrays.
    scenario : str
        One of :data:`SCENARIOS`.

    Returns
    -------
    radcons.io.Pair
        ``reference`` and ``target`` (uint16 digital numbers; the bit depth of each is in
        the metadata), ``disparity`` (float32 px, reference frame,
        ``reference(x, y) <-> target(x - d, y)``, NaN where the target does not see the
        point: hidden behind a taller surface or outside the target image),
        ``reference_objects`` / ``target_objects`` (int32 building ids, 0 = background,
        target walls belong to their building), ``change_mask`` (bool, reference frame:
        moved cars, added or demolished building, cut or planted trees, dug lawns, the
        shadows they cast and what they hide in the target view; inside it the
        disparity describes the reference date) and ``metadata`` (TOML-writable
        description of the geometry, dates, sensors and changes).

    Raises
    ------
    InputError
        Size outside 64..4096, unknown scenario or a negative or non-integer seed.
    """
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or not MIN_SIZE <= size <= MAX_SIZE:
        raise InputError(f"size must be an integer in {MIN_SIZE}..{MAX_SIZE}, got {size!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    if scenario not in SCENARIOS:
        raise InputError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}")
    size, seed = int(size), int(seed)
    temporal = scenario in ("multi-temporal", "mixed")
    other_sensor = scenario in ("multi-sensor", "mixed")
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(7)]

    grid = _grid(size)
    visible = Rect(0.0, 0.0, SCENE_EXTENT_M, SCENE_EXTENT_M)
    scene = city_layout(streams[_LAYOUT], _region(grid), visible)
    textures = make_textures(streams[_TEXTURE], grid)
    ref_sun = Sun(float(streams[_REF_DATE].uniform(55.0, 68.0)), float(streams[_REF_DATE].uniform(135.0, 170.0)))
    tgt_sun, radiometry = _other_date(streams[_TGT_DATE], ref_sun)
    glare_id = _glare_building(scene, visible)
    tgt_scene, changes = date_changes(streams[_CHANGES], scene, visible, protect=glare_id)

    ground = paint_ground(scene, grid, textures)
    ref_layers = rasterize(scene, grid, textures, ground)
    ref_lit = cast_shadows(ref_layers.height, grid.gsd, ref_sun)
    ref_radiance = _band_limit(shade(ref_layers.albedo, ref_layers.normal, ref_lit, ref_sun))
    if temporal:
        tgt_layers = rasterize(tgt_scene, grid, textures, ground)
        tgt_lit = cast_shadows(tgt_layers.height, grid.gsd, tgt_sun)
        tgt_radiance = shade(tgt_layers.albedo, tgt_layers.normal, tgt_lit, tgt_sun)
        glare_gain = _add_glare(tgt_radiance, tgt_layers.labels, glare_id, radiometry)
        tgt_radiance = _band_limit(tgt_radiance)
    else:
        tgt_scene, tgt_layers, tgt_sun, radiometry = scene, ref_layers, ref_sun, Radiometry()
        tgt_radiance, glare_gain = ref_radiance, 1.0

    ref_columns = target_columns(ref_layers.height, grid, STEREO, size)
    tgt_columns = target_columns(tgt_layers.height, grid, STEREO, size) if temporal else ref_columns
    view = target_view(tgt_layers, tgt_columns, grid, size)
    facades = _facades(tgt_scene)
    tgt_image = render_target(view, tgt_radiance, facades, tgt_sun, grid, STEREO, size)
    ref_image = _crop(ref_radiance, grid, size)
    tgt_sensor = OTHER_SENSOR if other_sensor else REFERENCE_SENSOR
    reference = acquire(ref_image, Radiometry(), REFERENCE_SENSOR, streams[_REF_NOISE])
    target = acquire(tgt_image, radiometry, tgt_sensor, streams[_TGT_NOISE])

    seen = visible_in_target(ref_columns, tgt_columns, grid, size)
    disp = disparity(ref_layers.height, grid, STEREO, size, seen)
    if temporal:
        seen_before = visible_in_target(ref_columns, ref_columns, grid, size)
        change = _change_mask(ref_layers, tgt_layers, tgt_lit, grid, tgt_sun, size, seen != seen_before)
    else:
        change = np.zeros((size, size), bool)

    metadata = _metadata(
        size, seed, scenario, grid, scene, ref_sun, tgt_sun, radiometry, tgt_sensor,
        changes if temporal else None, glare_id if temporal else 0, glare_gain,
    )
    return Pair(
        reference=Raster(reference),
        target=Raster(target),
        disparity=disp,
        reference_objects=_crop(ref_layers.labels, grid, size).astype(np.int32),
        target_objects=view.labels,
        change_mask=change,
        rectified=True,
        metadata=metadata,
        name=f"demo-{scenario}-seed{seed}-{size}px",
    )


def _grid(size: int) -> Grid:
    """The rendering grid: the image plus the pad, and on the right what the tilted view sees."""
    gsd = SCENE_EXTENT_M / size
    pad = int(math.ceil(PAD_M / gsd))
    right = int(math.ceil((STEREO.base + STEREO.ratio * MAX_HEIGHT_M + 2.0) / gsd))
    return Grid(gsd=gsd, row0=pad, col0=pad, shape=(size + 2 * pad, size + right + 2 * pad))


def _region(grid: Grid) -> Region:
    g = grid.gsd
    return Region(-grid.col0 * g, -grid.row0 * g, (grid.shape[1] - grid.col0) * g, (grid.shape[0] - grid.row0) * g)


def _band_limit(radiance: np.ndarray) -> np.ndarray:
    """Apply the shared optical blur :data:`SCENE_BLUR_PX` to a radiance field."""
    return cv2.GaussianBlur(radiance, (0, 0), SCENE_BLUR_PX, borderType=cv2.BORDER_REFLECT)


def _crop(world: np.ndarray, grid: Grid, size: int) -> np.ndarray:
    """The reference image's part of a grid array."""
    return np.ascontiguousarray(world[grid.row0 : grid.row0 + size, grid.col0 : grid.col0 + size])


def _other_date(rng: np.random.Generator, ref_sun: Sun) -> tuple[Sun, Radiometry]:
    """Sun and radiometric transfer of the target date (drawn whatever the scenario)."""
    elevation = float(rng.uniform(30.0, 42.0))
    azimuth = float((ref_sun.azimuth + rng.choice([-1.0, 1.0]) * rng.uniform(40.0, 70.0)) % 360.0)
    sun = Sun(elevation, azimuth)
    # the exposure roughly compensates the weaker sun; what remains is the date's difference
    exposure = (ref_sun.vector()[2] + ref_sun.ambient) / (sun.vector()[2] + sun.ambient)
    gain = float(exposure * rng.choice([rng.uniform(0.78, 0.9), rng.uniform(1.12, 1.3)]))
    offset = float(rng.uniform(-0.03, 0.06))
    gamma = float(rng.choice([rng.uniform(0.72, 0.86), rng.uniform(1.15, 1.3)]))
    return sun, Radiometry(gain, offset, gamma)


def _glare_building(scene: Scene, visible: Rect) -> int:
    """The largest flat roof well inside both views, below the tallest building: it will glare."""
    # the target view moves roofs left by up to r * 60 m = 15 m
    inner = Rect(visible.x0 + 25.0, visible.y0 + 10.0, visible.x1 - 10.0, visible.y1 - 10.0)
    tallest = max((b.top for b in scene.buildings), default=0.0)
    candidates = [b for b in scene.buildings if b.roof == "flat" and b.top < tallest and inner.contains(b.outer)]
    if not candidates:
        return 0
    return max(candidates, key=lambda b: b.outer.width * b.outer.height).id


def _add_glare(radiance: np.ndarray, labels: np.ndarray, ident: int, radiometry: Radiometry) -> float:
    """Brighten one roof so that it saturates at the target date; return the factor."""
    roof = labels == ident
    if ident == 0 or not roof.any():
        return 1.0
    level = float(np.median(radiance[roof]))
    gain = max(1.0, (GLARE_LEVEL - radiometry.offset) / (radiometry.gain * max(level, 1e-3)))
    radiance[roof] *= gain
    return gain


def _facades(scene: Scene) -> Facades:
    """Per-id facade tables (id 0 holds harmless defaults)."""
    top = max((b.id for b in scene.buildings), default=0) + 1
    tables = {
        "wall_albedo": np.full(top, 0.4), "window_albedo": np.full(top, 0.1),
        "floor_height": np.full(top, 3.0), "window_spacing": np.full(top, 3.0),
    }
    for b in scene.buildings:
        for key, table in tables.items():
            table[b.id] = getattr(b, key)
    return Facades(**tables)


def _change_mask(
    ref: Layers, tgt: Layers, tgt_lit: np.ndarray, grid: Grid, tgt_sun: Sun, size: int, seen_differs: np.ndarray
) -> np.ndarray:
    """Reference pixels whose appearance in the target changed because the scene changed.

    Changed are: a different surface height or albedo, a different shadow under the
    target's sun (the shadow a new or vanished object casts, ``tgt_lit`` against the
    reference scene under the same sun), and a different visibility in the target view
    (``seen_differs``: ground hidden by a new building or revealed by a demolished one);
    grown by one pixel.
    """
    lit_before = cast_shadows(ref.height, grid.gsd, tgt_sun)
    world = (
        (np.abs(ref.height - tgt.height) > 0.05)
        | (np.abs(ref.albedo - tgt.albedo) > 0.005)
        | (np.abs(lit_before - tgt_lit) > 0.25)
    )
    mask = _crop(world, grid, size) | seen_differs
    return cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def _metadata(
    size: int, seed: int, scenario: str, grid: Grid, scene: Scene, ref_sun: Sun, tgt_sun: Sun,
    radiometry: Radiometry, tgt_sensor: Sensor, changes, glare_id: int, glare_gain: float,
) -> dict:
    """Flat, TOML-writable description of the pair."""
    tgt_date = OTHER_DATE if changes is not None else REFERENCE_DATE
    inside = [b for b in scene.buildings if b.outer.intersects(Rect(0.0, 0.0, SCENE_EXTENT_M, SCENE_EXTENT_M))]
    meta = {
        "generator": "demo_data_gen",
        "scenario": scenario,
        "seed": seed,
        "size": size,
        "gsd_m": grid.gsd,
        "scene_extent_m": SCENE_EXTENT_M,
        "sensor": f"{REFERENCE_SENSOR.name} / {tgt_sensor.name}",
        "date": f"{REFERENCE_DATE} / {tgt_date}",
        "disparity_model": "d = (base_m + base_to_height * height_m) / gsd_m; NaN where the target does not see the point",
        "base_m": STEREO.base,
        "base_to_height": STEREO.ratio,
        "ground_disparity_px": STEREO.base / grid.gsd,
        "px_per_m_height": STEREO.ratio / grid.gsd,
        "buildings": len(inside),
        "max_building_height_m": max((b.top for b in inside), default=0.0),
        "reference_date": REFERENCE_DATE,
        "target_date": tgt_date,
        "reference_sensor": REFERENCE_SENSOR.name,
        "target_sensor": tgt_sensor.name,
        "reference_sun_elevation_deg": ref_sun.elevation,
        "reference_sun_azimuth_deg": ref_sun.azimuth,
        "target_sun_elevation_deg": tgt_sun.elevation,
        "target_sun_azimuth_deg": tgt_sun.azimuth,
        "reference_gain": 1.0,
        "reference_offset": 0.0,
        "reference_gamma": 1.0,
        "target_gain": radiometry.gain,
        "target_offset": radiometry.offset,
        "target_gamma": radiometry.gamma,
        "reference_bit_depth": REFERENCE_SENSOR.bit_depth,
        "target_bit_depth": tgt_sensor.bit_depth,
        "reference_noise_sigma_dn": REFERENCE_SENSOR.noise_sigma,
        "target_noise_sigma_dn": tgt_sensor.noise_sigma,
        "reference_blur_sigma_px": math.hypot(SCENE_BLUR_PX, REFERENCE_SENSOR.blur_sigma),
        "target_blur_sigma_px": math.hypot(SCENE_BLUR_PX, tgt_sensor.blur_sigma),
        "overexposed_object": glare_id,
        "overexposure_gain": glare_gain,
    }
    if changes is not None:
        meta.update(
            added_building=changes.added_building,
            removed_building=changes.removed_building,
            cars_moved=changes.cars_moved,
            trees_removed=changes.trees_removed,
            trees_planted=changes.trees_planted,
            lawns_dug=changes.lawns_dug,
        )
    return meta
