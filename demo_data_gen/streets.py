"""Ground plan of a city quarter: the street grid, its markings, and the parcels between.

Roads run across the whole region in both directions with sidewalks on either side; the
blocks between them are cut into lots, each given a use (building, houses, park, parking,
yard, or the construction site). Parking bays and site tracks are painted on their lots.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from demo_data_gen.scene import Lot, Paint, Rect, Region

__all__ = ["street_grid", "parcels", "choose_site", "lot_paint", "bays"]


def street_grid(
    rng: np.random.Generator, region: Region
) -> tuple[list[Rect], list[Rect], list[Paint], list[Rect]]:
    """Draw roads across the region, their sidewalks and markings, and the blocks between.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    region : Region
        Area the roads cross (metres).

    Returns
    -------
    roads : list of Rect
        Carriageways, first those running along ``y``, then those along ``x``.
    sidewalks : list of Rect
        The pavements on both sides of each road.
    paint : list of Paint
        Centre lines, edge lines and zebra crossings of every road.
    blocks : list of Rect
        The areas between the roads (clipped to the region), larger than 8 m x 8 m.
    """
    roads: list[Rect] = []
    sidewalks: list[Rect] = []
    paint: list[Paint] = []
    spans: dict[bool, list[tuple[float, float]]] = {}
    for along_x in (False, True):
        lo, hi = (region.y0, region.y1) if along_x else (region.x0, region.x1)
        edges = []
        for centre in _cuts(rng, lo, hi, (85.0, 125.0)):
            half = 0.5 * rng.uniform(9.0, 14.0)
            walk = rng.uniform(2.0, 3.5)
            edges.append((centre - half - walk, centre - half, centre + half, centre + half + walk))
        spans[along_x] = [(a, d) for a, _, _, d in edges]
        for a, b, c, d in edges:
            if along_x:
                roads.append(Rect(region.x0, b, region.x1, c))
                sidewalks += [Rect(region.x0, a, region.x1, b), Rect(region.x0, c, region.x1, d)]
            else:
                roads.append(Rect(b, region.y0, c, region.y1))
                sidewalks += [Rect(a, region.y0, b, region.y1), Rect(c, region.y0, d, region.y1)]
    crossings = [(x, y) for x in spans[False] for y in spans[True]]
    for road in roads:
        paint += _road_marks(road, crossings)
    blocks = []
    xs = [region.x0 - 50.0] + [v for span in spans[False] for v in span] + [region.x1 + 50.0]
    ys = [region.y0 - 50.0] + [v for span in spans[True] for v in span] + [region.y1 + 50.0]
    for i in range(0, len(xs), 2):
        for j in range(0, len(ys), 2):
            block = Rect(max(xs[i], region.x0), max(ys[j], region.y0), min(xs[i + 1], region.x1), min(ys[j + 1], region.y1))
            if block.width > 8 and block.height > 8:
                blocks.append(block)
    return roads, sidewalks, paint, blocks


def _cuts(rng: np.random.Generator, lo: float, hi: float, spacing: tuple[float, float]) -> list[float]:
    """Road centre positions across ``[lo, hi]`` with random spacing."""
    positions = [lo + rng.uniform(0.25, 0.75) * spacing[0]]
    while positions[-1] < hi:
        positions.append(positions[-1] + rng.uniform(*spacing))
    return positions


def _road_marks(road: Rect, crossings: list[tuple[tuple[float, float], tuple[float, float]]]) -> list[Paint]:
    """Dashed centre line, edge lines and zebra crossings of one carriageway."""
    along_x = road.width > road.height
    marks: list[Paint] = []
    if along_x:
        lo, hi, c0, c1 = road.x0, road.x1, road.y0, road.y1
        inter = sorted(x for x, _ in crossings)
    else:
        lo, hi, c0, c1 = road.y0, road.y1, road.x0, road.x1
        inter = sorted(y for _, y in crossings)
    mid = 0.5 * (c0 + c1)
    stretches = []
    start = lo
    for a, b in inter:
        stretches.append((start, a))
        start = b
    stretches.append((start, hi))

    def rect(s0: float, s1: float, t0: float, t1: float) -> Rect:
        return Rect(s0, t0, s1, t1) if along_x else Rect(t0, s0, t1, s1)

    for s0, s1 in stretches:
        if s1 - s0 < 12:
            continue
        inner0, inner1 = s0 + 5.0, s1 - 5.0
        s = inner0
        while s + 3.0 < inner1:
            marks.append(Paint(rect(s, s + 3.0, mid - 0.2, mid + 0.2), 0.62))
            s += 8.0
        for t in (c0 + 0.4, c1 - 0.8):
            marks.append(Paint(rect(inner0, inner1, t, t + 0.4), 0.55))
        for zebra0, direction in ((s0 + 0.8, 1.0), (s1 - 0.8, -1.0)):
            stop = zebra0 + direction * 4.0
            marks.append(Paint(rect(min(stop, stop + direction * 0.5), max(stop, stop + direction * 0.5), c0, mid), 0.6))
            t = c0 + 0.6
            while t + 0.6 < c1 - 0.4:
                marks.append(Paint(rect(min(zebra0, zebra0 + direction * 3.0), max(zebra0, zebra0 + direction * 3.0), t, t + 0.6), 0.65))
                t += 1.3
    return marks


def parcels(rng: np.random.Generator, blocks: list[Rect]) -> list[Lot]:
    """Split each block into lots and draw what each lot is used for.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    blocks : list of Rect
        Blocks between the roads, as from :func:`street_grid`.

    Returns
    -------
    list of Lot
        The lots, each used for ``"building"``, ``"houses"``, ``"park"``, ``"parking"``
        or ``"yard"``.
    """
    lots: list[Lot] = []
    for block in blocks:
        limit = rng.uniform(48.0, 68.0)
        stack = [block]
        while stack:
            part = stack.pop()
            if max(part.width, part.height) <= limit or min(part.width, part.height) < 24:
                use = rng.choice(["building", "houses", "park", "parking", "yard"], p=[0.5, 0.14, 0.16, 0.1, 0.1])
                lots.append(Lot(part, str(use), bool(rng.random() < 0.6)))
                continue
            f = rng.uniform(0.38, 0.62)
            if part.width >= part.height:
                cut = part.x0 + f * part.width
                stack += [Rect(part.x0, part.y0, cut, part.y1), Rect(cut, part.y0, part.x1, part.y1)]
            else:
                cut = part.y0 + f * part.height
                stack += [Rect(part.x0, part.y0, part.x1, cut), Rect(part.x0, cut, part.x1, part.y1)]
    return lots


def choose_site(rng: np.random.Generator, lots: list[Lot], visible: Rect) -> list[Lot]:
    """Turn one building lot well inside the image into a construction site.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    lots : list of Lot
        The lots of the quarter.
    visible : Rect
        The reference image's footprint; the site lies at least 5 m inside it.

    Returns
    -------
    list of Lot
        ``lots`` with one ``"building"`` lot made ``"construction"``; unchanged when no
        lot fits.
    """
    candidates = [
        i for i, lot in enumerate(lots)
        if lot.use == "building" and visible.shrink(5.0).contains(lot.rect)
        and min(lot.rect.width, lot.rect.height) >= 14
    ]
    if not candidates:
        return lots
    pick = candidates[int(rng.integers(len(candidates)))]
    lots = list(lots)
    lots[pick] = replace(lots[pick], use="construction")
    return lots


def lot_paint(rng: np.random.Generator, lots: list[Lot]) -> list[Paint]:
    """Paint parking bay lines and the tracks of a construction site.

    Parameters
    ----------
    rng : numpy.random.Generator
        The scene's random generator.
    lots : list of Lot
        The lots of the quarter.

    Returns
    -------
    list of Paint
        One line per parking bay and three pairs of tracks on the construction lot.
    """
    marks: list[Paint] = []
    for lot in lots:
        r = lot.rect.shrink(2.0)
        if lot.use == "parking":
            for bay in bays(lot):
                marks.append(Paint(Rect(bay.x0, bay.y0, bay.x0 + 0.15, bay.y1), 0.6))
        elif lot.use == "construction":
            for _ in range(3):
                y = rng.uniform(r.y0, r.y1 - 2.5)
                marks.append(Paint(Rect(r.x0, y, r.x1, y + 0.6), 0.2))
                marks.append(Paint(Rect(r.x0, y + 1.8, r.x1, y + 2.4), 0.2))
    return marks


def bays(lot: Lot) -> list[Rect]:
    """Lay out the parking bays of a lot.

    Parameters
    ----------
    lot : Lot
        A parking lot.

    Returns
    -------
    list of Rect
        Bays of 2.6 m x 5 m in back-to-back rows between 6.5 m aisles, 2 m in from the
        lot's edge.
    """
    r = lot.rect.shrink(2.0)
    spaces = []
    y = r.y0 + 0.5
    while y + 5.0 < r.y1:
        for row in (y, y + 5.0):
            if row + 5.0 >= r.y1:
                break
            x = r.x0 + 0.5
            while x + 2.6 < r.x1:
                spaces.append(Rect(x, row, x + 2.6, row + 5.0))
                x += 2.6
        y += 16.5
    return spaces
