"""Trees of a city quarter: groves in parks, a few in yards, and rows along sidewalks."""

from __future__ import annotations

import numpy as np

from demo_data_gen.scene import Building, Lot, Rect, Tree

__all__ = ["lot_trees", "street_trees"]


def lot_trees(rng: np.random.Generator, lots: list[Lot], buildings: list[Building], site: Building | None) -> list[Tree]:
    """Plant dense groves in parks and a few trees in yards, none on buildings or the site.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    lots : list of Lot
        The lots of the quarter; parking and construction lots stay bare.
    buildings : list of Building
        Buildings the crowns keep 0.5 m away from.
    site : Building or None
        The building to come on the construction lot, kept clear as well.

    Returns
    -------
    list of Tree
    """
    blocked = _footprints(buildings, site)
    trees: list[Tree] = []
    for lot in lots:
        if lot.use in ("parking", "construction"):
            continue
        r = lot.rect.shrink(1.0)
        count = int(r.width * r.height / 55.0) if lot.use == "park" else int(rng.integers(0, 5))
        for _ in range(count):
            radius = rng.uniform(1.8, 4.5)
            x, y = rng.uniform(r.x0 + radius, max(r.x0 + radius + 0.1, r.x1 - radius)), rng.uniform(r.y0 + radius, max(r.y0 + radius + 0.1, r.y1 - radius))
            crown = Rect(x - radius, y - radius, x + radius, y + radius)
            if any(crown.intersects(b, 0.5) for b in blocked):
                continue
            if any(np.hypot(t.x - x, t.y - y) < 0.8 * (t.radius + radius) for t in trees):
                continue
            trees.append(Tree(float(x), float(y), float(radius), float(radius * rng.uniform(1.5, 2.6) + 1.5), float(rng.uniform(0.1, 0.16))))
    return trees


def street_trees(
    rng: np.random.Generator, sidewalks: list[Rect], roads: list[Rect], buildings: list[Building], site: Building | None
) -> list[Tree]:
    """Plant rows of trees along some sidewalks, clear of crossings and buildings.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    sidewalks : list of Rect
        The pavements; about half of them get a row.
    roads : list of Rect
        The carriageways; no tree stands within 3 m of a crossing road.
    buildings : list of Building
        Buildings the crowns keep 0.5 m away from.
    site : Building or None
        The building to come on the construction lot, kept clear as well.

    Returns
    -------
    list of Tree
    """
    blocked = _footprints(buildings, site)
    trees: list[Tree] = []
    for walk in sidewalks:
        if rng.random() < 0.5:
            continue
        along_x = walk.width > walk.height
        lo, hi = (walk.x0, walk.x1) if along_x else (walk.y0, walk.y1)
        mid = 0.5 * (walk.y0 + walk.y1) if along_x else 0.5 * (walk.x0 + walk.x1)
        s = lo + rng.uniform(2.0, 10.0)
        while s < hi:
            x, y = (s, mid) if along_x else (mid, s)
            radius = rng.uniform(2.0, 3.2)
            crown = Rect(x - radius, y - radius, x + radius, y + radius)
            crossing = any(Rect(x - 3.0, y - 3.0, x + 3.0, y + 3.0).intersects(r) and (r.width > r.height) != along_x for r in roads)
            if not crossing and not any(crown.intersects(b, 0.5) for b in blocked):
                trees.append(Tree(float(x), float(y), float(radius), float(radius * rng.uniform(1.8, 2.4) + 2.0), float(rng.uniform(0.11, 0.16))))
            s += rng.uniform(9.0, 14.0)
    return trees


def _footprints(buildings: list[Building], site: Building | None) -> list[Rect]:
    """Outer footprints of the buildings and of the construction site's building."""
    return [b.outer for b in buildings] + ([site.outer] if site is not None else [])
