"""City layout in metres: roads, lots, buildings, trees and cars of one synthetic scene.

The layout is drawn from one random generator and does not depend on the image size: the
same seed gives the same city at every resolution. Coordinates are metres, ``x`` east and
``y`` south, with the reference image's top-left corner at ``(0, 0)``. The layout covers a
region larger than the image (``Region``) so that the oblique target view, which sees
ground beyond the reference frame, and shadows cast from just outside it are complete.

:func:`date_changes` derives the scene at the target date from the reference scene: cars
moved, one building added on the construction lot or one building demolished, trees cut
or planted, lawns dug up.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

__all__ = [
    "Rect",
    "Region",
    "Box",
    "Building",
    "Tree",
    "Car",
    "Paint",
    "Scene",
    "Changes",
    "city_layout",
    "date_changes",
]

#: Height of a car body (m).
CAR_HEIGHT = 1.45
#: Longest side of a building footprint (m).
MAX_SIDE = 40.0


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle ``[x0, x1) x [y0, y1)`` in metres."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0

    @property
    def centre(self) -> tuple[float, float]:
        return 0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1)

    def shrink(self, margin: float) -> "Rect":
        """Rectangle moved inwards by ``margin`` on every side."""
        return Rect(self.x0 + margin, self.y0 + margin, self.x1 - margin, self.y1 - margin)

    def contains(self, other: "Rect") -> bool:
        """True when ``other`` lies inside this rectangle."""
        return self.x0 <= other.x0 and other.x1 <= self.x1 and self.y0 <= other.y0 and other.y1 <= self.y1

    def intersects(self, other: "Rect", gap: float = 0.0) -> bool:
        """True when the rectangles overlap or come closer than ``gap``."""
        return not (
            self.x1 + gap <= other.x0
            or other.x1 + gap <= self.x0
            or self.y1 + gap <= other.y0
            or other.y1 + gap <= self.y0
        )


@dataclass(frozen=True)
class Region:
    """The metric area the scene is built on (larger than the reference image)."""

    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class Box:
    """A small box standing on a roof (air conditioning, lift housing, chimney)."""

    rect: Rect
    height: float
    albedo: float


@dataclass(frozen=True)
class Building:
    """A building: an axis-aligned footprint with cut-outs, walls and a roof.

    Attributes
    ----------
    id : int
        Object label (1, 2, ...), the same in both images.
    outer : Rect
        Bounding rectangle of the footprint.
    holes : tuple of Rect
        Parts of ``outer`` that are not building: the missing corner of an L, the
        courtyard of a courtyard block.
    shape : str
        ``"rectangle"``, ``"L"`` or ``"courtyard"``.
    eave : float
        Height of the walls above the ground (m); the flat roof's height.
    roof : str
        ``"flat"`` or ``"gabled"``.
    rise : float
        Height of a gable's ridge above the eaves (m); 0 for a flat roof.
    ridge_along_x : bool
        Orientation of a gable's ridge.
    albedo : float
        Roof reflectance.
    gravel : float
        Amplitude of the fine roof texture (gravel, tiles).
    equipment : tuple of Box
        Boxes on the roof.
    panels : tuple of Rect
        Dark flat panels (solar panels, skylights).
    wall_albedo, window_albedo : float
        Facade reflectances.
    floor_height, window_spacing : float
        Facade pattern periods (m).
    """

    id: int
    outer: Rect
    holes: tuple[Rect, ...]
    shape: str
    eave: float
    roof: str
    rise: float
    ridge_along_x: bool
    albedo: float
    gravel: float
    equipment: tuple[Box, ...]
    panels: tuple[Rect, ...]
    wall_albedo: float
    window_albedo: float
    floor_height: float
    window_spacing: float

    @property
    def top(self) -> float:
        """Highest point of the building above the ground (m)."""
        return self.eave + self.rise


@dataclass(frozen=True)
class Tree:
    """A tree crown: an ellipsoid cap of radius ``radius`` whose top is ``height`` m up."""

    x: float
    y: float
    radius: float
    height: float
    albedo: float


@dataclass(frozen=True)
class Car:
    """A car: a box of :data:`CAR_HEIGHT` on the ground."""

    rect: Rect
    albedo: float
    along_x: bool


@dataclass(frozen=True)
class Paint:
    """A flat coloured rectangle on the ground (road marking, lot surface)."""

    rect: Rect
    albedo: float


@dataclass(frozen=True)
class Lot:
    """A parcel of a block and what covers its ground."""

    rect: Rect
    use: str  # "building", "houses", "park", "parking", "construction", "yard"
    paved: bool


@dataclass(frozen=True)
class Scene:
    """Everything the renderer needs, in metres.

    ``roads`` are carriageways, ``sidewalks`` the pavements beside them, ``paint`` road
    and parking markings. ``site`` is the building that will stand on the construction lot
    at a later date (absent from this scene unless listed in ``buildings``).
    """

    region: Region
    terrain: tuple[float, float, float, float]
    roads: tuple[Rect, ...]
    sidewalks: tuple[Rect, ...]
    lots: tuple[Lot, ...]
    paint: tuple[Paint, ...]
    buildings: tuple[Building, ...]
    trees: tuple[Tree, ...]
    cars: tuple[Car, ...]
    site: Building | None
    bare_soil: tuple[Rect, ...] = field(default=())

    def ground_height(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Terrain height (m) at metric positions: a gentle tilt plus one long swell."""
        tx, ty, amp, phase = self.terrain
        r = self.region
        u = (np.asarray(x) - r.x0) / (r.x1 - r.x0)
        v = (np.asarray(y) - r.y0) / (r.y1 - r.y0)
        return tx * u + ty * v + amp * np.sin(2.0 * np.pi * (0.7 * u + 0.4 * v) + phase)


@dataclass(frozen=True)
class Changes:
    """What differs at the target date; ids are building labels, 0 where none."""

    added_building: int
    removed_building: int
    cars_moved: int
    trees_removed: int
    trees_planted: int
    lawns_dug: int


# --------------------------------------------------------------------------- layout


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
    roads, sidewalks, paint, blocks = _street_grid(rng, region)
    lots = _parcels(rng, blocks)
    lots = _choose_site(rng, lots, visible)
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
    buildings = _ensure_tower(rng, buildings, visible)
    paint += _lot_paint(rng, lots)
    trees = _trees(rng, lots, buildings, site) + _street_trees(rng, sidewalks, roads, buildings, site)
    cars = _road_cars(rng, roads, ()) + _parking_cars(rng, lots)
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


def _cuts(rng: np.random.Generator, lo: float, hi: float, spacing: tuple[float, float]) -> list[float]:
    """Road centre positions across ``[lo, hi]`` with random spacing."""
    positions = [lo + rng.uniform(0.25, 0.75) * spacing[0]]
    while positions[-1] < hi:
        positions.append(positions[-1] + rng.uniform(*spacing))
    return positions


def _street_grid(
    rng: np.random.Generator, region: Region
) -> tuple[list[Rect], list[Rect], list[Paint], list[Rect]]:
    """Roads across the region, their sidewalks and markings, and the blocks between."""
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


def _parcels(rng: np.random.Generator, blocks: list[Rect]) -> list[Lot]:
    """Split each block into lots and draw what each lot is used for."""
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


def _choose_site(rng: np.random.Generator, lots: list[Lot], visible: Rect) -> list[Lot]:
    """Turn one building lot well inside the image into a construction site."""
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


def _split(rect: Rect, parts: int) -> list[Rect]:
    """Cut a rectangle across its long side into equal parts."""
    if rect.width >= rect.height:
        edges = np.linspace(rect.x0, rect.x1, parts + 1)
        return [Rect(a, rect.y0, b, rect.y1) for a, b in zip(edges[:-1], edges[1:])]
    edges = np.linspace(rect.y0, rect.y1, parts + 1)
    return [Rect(rect.x0, a, rect.x1, b) for a, b in zip(edges[:-1], edges[1:])]


def _building(rng: np.random.Generator, ident: int, lot: Rect, max_side: float = MAX_SIDE, tallest: float = 40.0) -> Building:
    """A building on a lot: footprint, height, roof, roof furniture and facade.

    ``max_side`` bounds the footprint (a larger lot keeps a yard), ``tallest`` the eaves.
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


def _lot_paint(rng: np.random.Generator, lots: list[Lot]) -> list[Paint]:
    """Parking bay lines and the tracks of a construction site."""
    marks: list[Paint] = []
    for lot in lots:
        r = lot.rect.shrink(2.0)
        if lot.use == "parking":
            for bay in _bays(lot):
                marks.append(Paint(Rect(bay.x0, bay.y0, bay.x0 + 0.15, bay.y1), 0.6))
        elif lot.use == "construction":
            for _ in range(3):
                y = rng.uniform(r.y0, r.y1 - 2.5)
                marks.append(Paint(Rect(r.x0, y, r.x1, y + 0.6), 0.2))
                marks.append(Paint(Rect(r.x0, y + 1.8, r.x1, y + 2.4), 0.2))
    return marks


def _trees(rng: np.random.Generator, lots: list[Lot], buildings: list[Building], site: Building | None) -> list[Tree]:
    """Dense groves in parks, a few trees in yards, none on buildings or the site."""
    blocked = [b.outer for b in buildings] + ([site.outer] if site is not None else [])
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


def _street_trees(
    rng: np.random.Generator, sidewalks: list[Rect], roads: list[Rect], buildings: list[Building], site: Building | None
) -> list[Tree]:
    """Rows of trees along some sidewalks, clear of crossings and buildings."""
    blocked = [b.outer for b in buildings] + ([site.outer] if site is not None else [])
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


_CAR_ALBEDOS = np.array([0.06, 0.1, 0.2, 0.35, 0.55, 0.7, 0.8])


def _road_cars(rng: np.random.Generator, roads: tuple[Rect, ...] | list[Rect], keep: tuple[Car, ...]) -> list[Car]:
    """Cars parked or driving in both lanes of each road, clear of ``keep``."""
    cars: list[Car] = []
    for road in roads:
        along_x = road.width > road.height
        lo, hi = (road.x0, road.x1) if along_x else (road.y0, road.y1)
        c0, c1 = (road.y0, road.y1) if along_x else (road.x0, road.x1)
        for lane in (c0 + 0.25 * (c1 - c0), c0 + 0.75 * (c1 - c0)):
            s = lo + rng.exponential(40.0)
            while s < hi:
                length, width = rng.uniform(4.0, 5.0), rng.uniform(1.7, 1.95)
                t = lane + rng.normal(0.0, 0.3) - 0.5 * width
                rect = Rect(s, t, s + length, t + width) if along_x else Rect(t, s, t + width, s + length)
                if not any(rect.intersects(c.rect, 0.6) for c in keep):
                    cars.append(Car(rect, float(rng.choice(_CAR_ALBEDOS)), along_x))
                s += length + 1.5 + rng.exponential(40.0)
    return cars


def _parking_cars(rng: np.random.Generator, lots: list[Lot] | tuple[Lot, ...]) -> list[Car]:
    """Cars in the bays of parking lots."""
    cars: list[Car] = []
    for lot in lots:
        if lot.use != "parking":
            continue
        for bay in _bays(lot):
            if rng.random() < 0.6:
                w, length = rng.uniform(1.7, 1.95), rng.uniform(4.0, 4.7)
                cx = bay.x0 + 1.3 - 0.5 * w
                cars.append(Car(Rect(cx, bay.y0 + 0.2, cx + w, bay.y0 + 0.2 + length), float(rng.choice(_CAR_ALBEDOS)), False))
    return cars


def _bays(lot: Lot) -> list[Rect]:
    """Parking bays (2.6 m x 5 m) of a lot: back-to-back rows between 6.5 m aisles."""
    r = lot.rect.shrink(2.0)
    bays = []
    y = r.y0 + 0.5
    while y + 5.0 < r.y1:
        for row in (y, y + 5.0):
            if row + 5.0 >= r.y1:
                break
            x = r.x0 + 0.5
            while x + 2.6 < r.x1:
                bays.append(Rect(x, row, x + 2.6, row + 5.0))
                x += 2.6
        y += 16.5
    return bays


# --------------------------------------------------------------------------- changes


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
    new = _road_cars(rng, scene.roads, kept)
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
