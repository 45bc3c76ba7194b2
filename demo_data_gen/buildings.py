"""Buildings of a city quarter: footprints, heights, roofs, roof furniture and facades.

Each ``"building"`` lot gets one building, each ``"houses"`` lot a row of small ones, and
the construction lot the building that will stand there at a later date. One flat-roofed
building inside the image is raised to a tower.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from demo_data_gen.scene import Box, Building, Lot, Rect

__all__ = ["place_buildings"]

#: Longest side of a building footprint (m).
MAX_SIDE = 40.0


def place_buildings(rng: np.random.Generator, lots: list[Lot], visible: Rect) -> tuple[list[Building], Building | None]:
    """Build on the lots of a quarter.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    lots : list of Lot
        The lots of the quarter, as from :func:`demo_data_gen.streets.choose_site`.
    visible : Rect
        The reference image's footprint; the tower stands inside it.

    Returns
    -------
    buildings : list of Building
        The buildings standing at the reference date, labelled 1, 2, ... in lot order.
    site : Building or None
        The building on the construction lot (the next label), not among ``buildings``;
        None when there is no construction lot.
    """
    buildings: list[Building] = []
    site: Building | None = None
    next_id = 1
    for lot in lots:
        if lot.use == "building":
            buildings.append(_building(rng, next_id, lot.rect))
            next_id += 1
        elif lot.use == "houses":
            fits = int(max(lot.rect.width, lot.rect.height) // 12.0)
            for part in _split(lot.rect, max(1, min(int(rng.integers(2, 4)), fits))):
                buildings.append(_building(rng, next_id, part, max_side=16.0, tallest=9.0))
                next_id += 1
    for lot in lots:
        if lot.use == "construction":
            site = _building(rng, next_id, lot.rect.shrink(1.0))
    return _ensure_tower(rng, buildings, visible), site


def _split(rect: Rect, parts: int) -> list[Rect]:
    """Cut a rectangle across its long side into equal parts."""
    if rect.width >= rect.height:
        edges = np.linspace(rect.x0, rect.x1, parts + 1)
        return [Rect(a, rect.y0, b, rect.y1) for a, b in zip(edges[:-1], edges[1:])]
    edges = np.linspace(rect.y0, rect.y1, parts + 1)
    return [Rect(rect.x0, a, rect.x1, b) for a, b in zip(edges[:-1], edges[1:])]


def _building(rng: np.random.Generator, ident: int, lot: Rect, max_side: float = MAX_SIDE, tallest: float = 40.0) -> Building:
    """Draw a building on a lot: footprint, height, roof, roof furniture and facade.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    ident : int
        Object label of the building.
    lot : Rect
        The ground it stands on, setbacks included.
    max_side : float
        Longest side of the footprint (m); a larger lot keeps a yard.
    tallest : float
        Highest eaves (m).

    Returns
    -------
    Building
    """
    setback = rng.uniform(1.0, min(4.5, 0.15 * min(lot.width, lot.height)), size=4)
    outer = Rect(lot.x0 + setback[0], lot.y0 + setback[1], lot.x1 - setback[2], lot.y1 - setback[3])
    if outer.width > max_side:
        x0 = rng.uniform(outer.x0, outer.x1 - max_side)
        outer = replace(outer, x0=x0, x1=x0 + max_side)
    if outer.height > max_side:
        y0 = rng.uniform(outer.y0, outer.y1 - max_side)
        outer = replace(outer, y0=y0, y1=y0 + max_side)
    if rng.random() < 0.35:  # a narrower building leaves a yard beside it
        if outer.width > outer.height:
            outer = replace(outer, x1=outer.x0 + outer.width * rng.uniform(0.6, 0.9))
        else:
            outer = replace(outer, y1=outer.y0 + outer.height * rng.uniform(0.6, 0.9))
    short = min(outer.width, outer.height)
    shape_p = np.array([1.0, 0.6 if short >= 14 else 0.0, 0.5 if short >= 24 else 0.0])
    shape = str(rng.choice(["rectangle", "L", "courtyard"], p=shape_p / shape_p.sum()))
    holes: tuple[Rect, ...] = ()
    if shape == "L":
        fx, fy = rng.uniform(0.4, 0.62, size=2)
        cx = outer.x1 - fx * outer.width if rng.random() < 0.5 else outer.x0
        cy = outer.y1 - fy * outer.height if rng.random() < 0.5 else outer.y0
        holes = (Rect(cx, cy, cx + fx * outer.width, cy + fy * outer.height),)
    elif shape == "courtyard":
        ring = rng.uniform(6.5, 10.0)
        holes = (outer.shrink(ring),)
    gabled = shape == "rectangle" and short <= 22 and rng.random() < 0.55
    eave = float(np.clip(np.exp(rng.normal(np.log(13.0), 0.5)), 5.0, min(tallest, 40.0 if not gabled else 22.0)))
    ridge_along_x = outer.width >= outer.height
    rise = float(0.5 * short * np.tan(np.radians(rng.uniform(22.0, 38.0)))) if gabled else 0.0
    if gabled:
        albedo = float(rng.uniform(0.16, 0.3))
        gravel = 0.045
        equipment = _chimneys(rng, outer)
        panels: tuple[Rect, ...] = ()
    else:
        albedo = float(rng.choice([rng.uniform(0.32, 0.55), rng.uniform(0.18, 0.26), rng.uniform(0.5, 0.62)], p=[0.6, 0.25, 0.15]))
        gravel = float(rng.uniform(0.015, 0.04))
        equipment = _roof_boxes(rng, outer, holes)
        panels = _roof_panels(rng, outer, holes, equipment)
    return Building(
        id=ident,
        outer=outer,
        holes=holes,
        shape=shape,
        eave=eave,
        roof="gabled" if gabled else "flat",
        rise=rise,
        ridge_along_x=ridge_along_x,
        albedo=albedo,
        gravel=gravel,
        equipment=equipment,
        panels=panels,
        wall_albedo=float(rng.uniform(0.3, 0.55)),
        window_albedo=float(rng.uniform(0.06, 0.14)),
        floor_height=float(rng.uniform(2.9, 3.6)),
        window_spacing=float(rng.uniform(2.4, 4.0)),
    )


def _inside_footprint(rect: Rect, outer: Rect, holes: tuple[Rect, ...], margin: float) -> bool:
    """True when ``rect`` grown by ``margin`` lies on the footprint (outside its holes)."""
    grown = rect.shrink(-margin)
    return outer.contains(grown) and not any(grown.intersects(h) for h in holes)


def _roof_boxes(rng: np.random.Generator, outer: Rect, holes: tuple[Rect, ...]) -> tuple[Box, ...]:
    """Air-conditioning units and lift housings on a flat roof."""
    area = outer.width * outer.height
    boxes: list[Box] = []
    for _ in range(int(rng.integers(2, 4 + area // 120))):
        w, h = rng.uniform(1.0, max(1.1, min(4.5, min(outer.width, outer.height) / 3)), size=2)
        x = rng.uniform(outer.x0, outer.x1 - w)
        y = rng.uniform(outer.y0, outer.y1 - h)
        rect = Rect(x, y, x + w, y + h)
        if _inside_footprint(rect, outer, holes, 1.0) and not any(rect.intersects(b.rect, 1.0) for b in boxes):
            albedo = float(rng.choice([rng.uniform(0.55, 0.75), rng.uniform(0.15, 0.25)], p=[0.7, 0.3]))
            boxes.append(Box(rect, float(rng.uniform(1.0, 2.8)), albedo))
    return tuple(boxes)


def _roof_panels(rng: np.random.Generator, outer: Rect, holes: tuple[Rect, ...], boxes: tuple[Box, ...]) -> tuple[Rect, ...]:
    """Rows of dark solar panels or skylights on some flat roofs."""
    if rng.random() < 0.5:
        return ()
    panels: list[Rect] = []
    w, h = rng.uniform(3.0, 8.0), rng.uniform(1.0, 1.6)
    x = rng.uniform(outer.x0 + 1.5, max(outer.x0 + 1.6, outer.x1 - w - 1.5))
    y = rng.uniform(outer.y0 + 1.5, max(outer.y0 + 1.6, outer.y1 - 4 * h))
    for row in range(int(rng.integers(2, 5))):
        rect = Rect(x, y + row * 1.8 * h, x + w, y + row * 1.8 * h + h)
        if _inside_footprint(rect, outer, holes, 0.8) and not any(rect.intersects(b.rect, 0.5) for b in boxes):
            panels.append(rect)
    return tuple(panels)


def _chimneys(rng: np.random.Generator, outer: Rect) -> tuple[Box, ...]:
    """Chimneys and roof windows on a gable; their height is above the local roof."""
    boxes = []
    for _ in range(int(rng.integers(1, 4))):
        s = rng.uniform(0.8, 1.4)
        x = rng.uniform(outer.x0 + 1.5, outer.x1 - 1.5 - s)
        y = rng.uniform(outer.y0 + 1.5, outer.y1 - 1.5 - s)
        boxes.append(Box(Rect(x, y, x + s, y + s), float(rng.uniform(0.8, 1.5)), float(rng.uniform(0.25, 0.45))))
    return tuple(boxes)


def _ensure_tower(rng: np.random.Generator, buildings: list[Building], visible: Rect) -> list[Building]:
    """Raise one flat-roofed building inside the image to 40-60 m (a tower)."""
    inside = [
        i for i, b in enumerate(buildings)
        if b.roof == "flat" and visible.shrink(20.0).intersects(b.outer)
    ]
    if not inside:
        return buildings
    pick = inside[int(rng.integers(len(inside)))]
    buildings = list(buildings)
    buildings[pick] = replace(buildings[pick], eave=float(rng.uniform(40.0, 60.0)))
    return buildings

