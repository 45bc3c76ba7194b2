"""Scene model in metres: the rectangles, buildings, trees, cars and markings of a city.

Coordinates are metres, ``x`` east and ``y`` south, with the reference image's top-left
corner at ``(0, 0)``. A :class:`Scene` is what :func:`demo_data_gen.layout.city_layout`
draws and what the renderer rasterizes; :class:`Changes` summarises how the scene at the
target date differs from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "CAR_HEIGHT",
    "Rect",
    "Region",
    "Box",
    "Building",
    "Tree",
    "Car",
    "Paint",
    "Lot",
    "Scene",
    "Changes",
]

#: Height of a car body (m).
CAR_HEIGHT = 1.45


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle ``[x0, x1) x [y0, y1)`` in metres."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        """Extent along ``x`` (m)."""
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        """Extent along ``y`` (m)."""
        return self.y1 - self.y0

    @property
    def centre(self) -> tuple[float, float]:
        """Centre point ``(x, y)`` (m)."""
        return 0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1)

    def shrink(self, margin: float) -> Rect:
        """Rectangle moved inwards by ``margin`` on every side (outwards when negative)."""
        return Rect(self.x0 + margin, self.y0 + margin, self.x1 - margin, self.y1 - margin)

    def contains(self, other: Rect) -> bool:
        """True when ``other`` lies inside this rectangle."""
        return self.x0 <= other.x0 and other.x1 <= self.x1 and self.y0 <= other.y0 and other.y1 <= self.y1

    def intersects(self, other: Rect, gap: float = 0.0) -> bool:
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

