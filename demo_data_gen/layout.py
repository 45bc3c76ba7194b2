"""City layout in metres: the scene of one synthetic city quarter at both dates.

The layout is drawn from one random generator and does not depend on the image size: the
same seed gives the same city at every resolution. Coordinates are metres, ``x`` east and
``y`` south, with the reference image's top-left corner at ``(0, 0)``. The layout covers a
region larger than the image (``Region``) so that the oblique target view, which sees
ground beyond the reference frame, and shadows cast from just outside it are complete.

:func:`city_layout` composes the reference scene from the street grid and parcels
(:mod:`demo_data_gen.streets`), buildings (:mod:`demo_data_gen.buildings`), trees
(:mod:`demo_data_gen.trees`) and cars (:mod:`demo_data_gen.cars`); the scene model lives
in :mod:`demo_data_gen.scene`. :func:`date_changes` derives the scene at the target date
from the reference scene: cars moved, one building added on the construction lot or one
building demolished, trees cut or planted, lawns dug up.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from demo_data_gen.buildings import place_buildings
from demo_data_gen.cars import parking_cars, road_cars
from demo_data_gen.scene import Changes, Rect, Region, Scene, Tree
from demo_data_gen.streets import choose_site, lot_paint, parcels, street_grid
from demo_data_gen.trees import lot_trees, street_trees

__all__ = ["city_layout", "date_changes"]


def city_layout(rng: np.random.Generator, region: Region, visible: Rect) -> Scene:
    """Draw a city quarter: a street grid, parcels, buildings, trees and cars.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator; the layout uses nothing else.
    region : Region
        Area to fill (metres).
    visible : Rect
        The reference image's footprint; the tallest building and the construction site
        are placed inside it.

    Returns
    -------
    Scene
    """
    roads, sidewalks, paint, blocks = street_grid(rng, region)
    lots = choose_site(rng, parcels(rng, blocks), visible)
    buildings, site = place_buildings(rng, lots, visible)
    paint += lot_paint(rng, lots)
    trees = lot_trees(rng, lots, buildings, site) + street_trees(rng, sidewalks, roads, buildings, site)
    cars = road_cars(rng, roads, ()) + parking_cars(rng, lots)
    terrain = (
        float(rng.uniform(-2.0, 2.0)),
        float(rng.uniform(-2.0, 2.0)),
        float(rng.uniform(0.4, 1.2)),
        float(rng.uniform(0.0, 2 * np.pi)),
    )
    return Scene(
        region=region,
        terrain=terrain,
        roads=tuple(roads),
        sidewalks=tuple(sidewalks),
        lots=tuple(lots),
        paint=tuple(paint),
        buildings=tuple(buildings),
        trees=tuple(trees),
        cars=tuple(cars),
        site=site,
    )


def date_changes(rng: np.random.Generator, scene: Scene, visible: Rect, protect: int) -> tuple[Scene, Changes]:
    """Derive the scene at another date.

    Roads, sidewalks, lots and markings stay as they are (the renderer paints them once
    for both dates); buildings, cars, trees and bare soil change.

    Parameters
    ----------
    rng : numpy.random.Generator
        The target date's random generator.
    scene : Scene
        The scene at the reference date.
    visible : Rect
        The reference image's footprint; changes are placed inside it.
    protect : int
        A building id that must stay (the over-exposed object).

    Returns
    -------
    Scene
        The scene at the target date.
    Changes
        What changed.
    """
    buildings = list(scene.buildings)
    added = removed = 0
    candidates = [
        b for b in buildings
        if b.id != protect and visible.shrink(15.0).intersects(b.outer) and b.top < 40.0
    ]
    if scene.site is not None and (rng.random() < 0.5 or not candidates):
        buildings.append(scene.site)
        added = scene.site.id
    elif candidates:
        gone = candidates[int(rng.integers(len(candidates)))]
        buildings.remove(gone)
        removed = gone.id
    kept = tuple(c for c in scene.cars if rng.random() < 0.45)
    new = road_cars(rng, scene.roads, kept)
    cars = kept + tuple(c for c in new if rng.random() < 0.5)
    trees = [t for t in scene.trees if rng.random() >= 0.15]
    cut = len(scene.trees) - len(trees)
    planted = []
    parks = [lot for lot in scene.lots if lot.use in ("park", "yard")]
    for _ in range(int(rng.integers(2, 6)) if parks else 0):
        lot = parks[int(rng.integers(len(parks)))].rect.shrink(3.0)
        if lot.width <= 0 or lot.height <= 0:
            continue
        x, y = rng.uniform(lot.x0, lot.x1), rng.uniform(lot.y0, lot.y1)
        if all(np.hypot(t.x - x, t.y - y) > t.radius + 2.0 for t in trees):
            planted.append(Tree(float(x), float(y), float(rng.uniform(1.2, 2.0)), float(rng.uniform(3.0, 5.0)), float(rng.uniform(0.1, 0.16))))
    lawns = [lot.rect.shrink(rng.uniform(2.0, 5.0)) for lot in parks if rng.random() < 0.3 and visible.intersects(lot.rect)]
    lawns = [r for r in lawns if r.width > 4 and r.height > 4][:2]
    if removed:
        lawns.append(next(b for b in scene.buildings if b.id == removed).outer)
    changed = replace(
        scene,
        buildings=tuple(buildings),
        cars=cars,
        trees=tuple(trees + planted),
        bare_soil=tuple(lawns),
    )
    return changed, Changes(
        added_building=added,
        removed_building=removed,
        cars_moved=len(scene.cars) - len(kept) + len(cars) - len(kept),
        trees_removed=cut,
        trees_planted=len(planted),
        lawns_dug=len(lawns) - (1 if removed else 0),
    )
