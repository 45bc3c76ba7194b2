"""Rasterise a metric scene onto a pixel grid: height, albedo, surface normals, labels.

The grid is "orthographic from above" (the reference view). Flat markings and ground
materials are drawn with exact area coverage (anti-aliased); anything with height
(buildings, roof boxes, cars, trees) is drawn by pixel centre so that heights and labels
stay crisp. Textures are band-limited noise fields defined on the grid and shared by the
scenes of both dates, so an unchanged surface has the same texture at both dates.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from demo_data_gen.scene import CAR_HEIGHT, Building, Rect, Scene

__all__ = ["Grid", "Textures", "Layers", "make_textures", "paint_ground", "rasterize"]


@dataclass(frozen=True)
class Grid:
    """A pixel grid over the scene.

    Pixel ``(row, col)`` of the grid covers metres ``[(col - col0) g, (col - col0 + 1) g)``
    in x (and likewise in y), so reference pixel ``(r, c)`` is grid pixel
    ``(r + row0, c + col0)``.

    Attributes
    ----------
    gsd : float
        Ground sampling distance ``g`` (m per pixel).
    row0, col0 : int
        Grid index of the reference image's pixel (0, 0).
    shape : tuple of int
        Grid size (rows, columns).
    """

    gsd: float
    row0: int
    col0: int
    shape: tuple[int, int]

    def x(self) -> np.ndarray:
        """Metric x of the pixel centres of each column."""
        return ((np.arange(self.shape[1]) - self.col0 + 0.5) * self.gsd).astype(np.float32)

    def y(self) -> np.ndarray:
        """Metric y of the pixel centres of each row."""
        return ((np.arange(self.shape[0]) - self.row0 + 0.5) * self.gsd).astype(np.float32)

    def window(self, rect: Rect, pad: int = 1) -> tuple[slice, slice]:
        """Grid slices covering ``rect`` plus ``pad`` pixels, clipped to the grid."""
        g = self.gsd
        c0 = max(int(np.floor(rect.x0 / g)) + self.col0 - pad, 0)
        c1 = min(int(np.ceil(rect.x1 / g)) + self.col0 + pad, self.shape[1])
        r0 = max(int(np.floor(rect.y0 / g)) + self.row0 - pad, 0)
        r1 = min(int(np.ceil(rect.y1 / g)) + self.row0 + pad, self.shape[0])
        return slice(r0, max(r0, r1)), slice(c0, max(c0, c1))

    def coverage(self, rect: Rect, rows: slice, cols: slice) -> np.ndarray:
        """Fraction of each pixel of the window covered by ``rect`` (exact area)."""
        g = self.gsd
        left = (np.arange(cols.start, cols.stop) - self.col0) * g
        top = (np.arange(rows.start, rows.stop) - self.row0) * g
        cx = np.clip(np.minimum(left + g, rect.x1) - np.maximum(left, rect.x0), 0.0, g) / g
        cy = np.clip(np.minimum(top + g, rect.y1) - np.maximum(top, rect.y0), 0.0, g) / g
        return (cy[:, None] * cx[None, :]).astype(np.float32)

    def centres_in(self, rect: Rect, rows: slice, cols: slice) -> np.ndarray:
        """True for the window's pixels whose centre lies in ``rect``."""
        x = self.x()[cols]
        y = self.y()[rows]
        inx = (x >= rect.x0) & (x < rect.x1)
        iny = (y >= rect.y0) & (y < rect.y1)
        return iny[:, None] & inx[None, :]


@dataclass(frozen=True)
class Textures:
    """Unit-variance band-limited noise fields on the grid, one per length scale.

    ``fine`` has a correlation length of about one pixel, the others of the named number
    of metres (never less than a pixel).
    """

    fine: np.ndarray
    m05: np.ndarray
    m2: np.ndarray
    m8: np.ndarray
    m30: np.ndarray


@dataclass
class Layers:
    """The scene rasterised on a grid.

    Attributes
    ----------
    height : ndarray, float32
        Surface height (m).
    ground : ndarray, float32
        Terrain height under the surface (m).
    albedo : ndarray, float32
        Reflectance in 0..1.
    normal : ndarray, float32, shape (3, rows, cols)
        Unit surface normal (east, south, up).
    labels : ndarray, int32
        Building id, 0 elsewhere.
    """

    height: np.ndarray
    ground: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    labels: np.ndarray


def _noise(rng: np.random.Generator, shape: tuple[int, int], scale_px: float) -> np.ndarray:
    """Gaussian noise with correlation length ``scale_px`` pixels, unit variance."""
    if scale_px <= 2.0:
        field = rng.standard_normal(shape, dtype=np.float32)
        field = cv2.GaussianBlur(field, (0, 0), max(0.5 * scale_px, 0.7), borderType=cv2.BORDER_REFLECT)
    else:
        coarse = (int(np.ceil(shape[0] / scale_px)) + 4, int(np.ceil(shape[1] / scale_px)) + 4)
        field = rng.standard_normal(coarse, dtype=np.float32)
        field = cv2.GaussianBlur(field, (0, 0), 0.7, borderType=cv2.BORDER_REFLECT)
        size = (int(round(coarse[1] * scale_px)), int(round(coarse[0] * scale_px)))
        field = cv2.resize(field, size, interpolation=cv2.INTER_CUBIC)
        off = int(scale_px)
        field = np.ascontiguousarray(field[off : off + shape[0], off : off + shape[1]])
    field -= field.mean()
    field /= max(float(field.std()), 1e-6)
    return field


def make_textures(rng: np.random.Generator, grid: Grid) -> Textures:
    """Draw the noise fields of a grid from ``rng``."""
    g = grid.gsd
    return Textures(
        fine=_noise(rng, grid.shape, 1.0),
        m05=_noise(rng, grid.shape, max(0.5 / g, 1.0)),
        m2=_noise(rng, grid.shape, max(2.0 / g, 1.0)),
        m8=_noise(rng, grid.shape, max(8.0 / g, 1.0)),
        m30=_noise(rng, grid.shape, max(30.0 / g, 1.0)),
    )


def _stripes(coord: np.ndarray, period_m: float, gsd: float) -> np.ndarray:
    """A cosine of period ``period_m``, faded out where the grid cannot resolve it."""
    fade = float(np.clip((period_m / gsd - 2.5) / 2.5, 0.0, 1.0))
    if fade == 0.0:
        return np.zeros_like(coord)
    return fade * np.cos(2.0 * np.pi * coord / period_m)


def _soil(tex: Textures) -> np.ndarray:
    """Albedo of bare soil (construction sites, dug lawns)."""
    return 0.3 + 0.035 * tex.m2 + 0.025 * tex.m8 + 0.012 * tex.fine


def _materials(tex: Textures) -> dict[str, np.ndarray]:
    """Ground materials as albedo fields."""
    return {
        "grass": 0.16 + 0.02 * tex.m2 + 0.015 * tex.m05 + 0.01 * tex.fine,
        "soil": _soil(tex),
        "paved": 0.27 + 0.015 * tex.m2 + 0.012 * tex.fine + 0.008 * tex.m8,
        "asphalt": 0.12 + 0.012 * tex.m05 + 0.008 * tex.fine + 0.02 * tex.m8,
        "sidewalk": 0.31 + 0.015 * tex.m05 + 0.01 * tex.fine + 0.015 * tex.m8,
    }


def paint_ground(scene: Scene, grid: Grid, tex: Textures) -> np.ndarray:
    """Albedo of the bare ground: natural ground, lots, sidewalks, roads, markings.

    These do not change between the dates (see :func:`demo_data_gen.layout.date_changes`),
    so one painting serves both scenes of a pair.

    Returns
    -------
    ndarray, float32
    """
    materials = _materials(tex)
    mix = 1.0 / (1.0 + np.exp(-4.0 * (0.6 * tex.m30 + 0.4 * tex.m8 - 0.3)))
    albedo = mix * (0.24 + 0.03 * tex.m8 + 0.02 * tex.m05 + 0.01 * tex.fine) + (1.0 - mix) * materials["grass"]
    lot_material = {"park": "grass", "parking": "asphalt", "construction": "soil"}
    by_material: dict[str, list[Rect]] = {}
    for lot in scene.lots:
        name = lot_material.get(lot.use, "paved" if lot.paved else "grass")
        by_material.setdefault(name, []).append(lot.rect)
    covers = {name: np.minimum(_rect_sum(grid, rects), 1.0) for name, rects in by_material.items()}
    total = sum(covers.values())
    albedo = albedo * (1.0 - total) + sum(cover * materials[name] for name, cover in covers.items())
    for name, rects in (("sidewalk", scene.sidewalks), ("asphalt", scene.roads)):
        cover = np.minimum(_rect_sum(grid, rects), 1.0)
        albedo += cover * (materials[name] - albedo)
    marks = [m.rect for m in scene.paint]
    cover = _rect_sum(grid, marks)
    paint = _rect_sum(grid, marks, [m.albedo for m in scene.paint])
    paint = paint / np.maximum(cover, 1e-6) + 0.02 * tex.fine
    cover = np.minimum(cover, 1.0)
    return (albedo * (1.0 - cover) + cover * paint).astype(np.float32)


def rasterize(scene: Scene, grid: Grid, tex: Textures, ground_albedo: np.ndarray) -> Layers:
    """Draw ``scene`` on ``grid`` over the painted ground.

    Bare soil (dug lawns, demolition sites) goes on the ground first, then buildings with
    their roof furniture, cars, and tree crowns on top.

    Parameters
    ----------
    scene : Scene
    grid : Grid
    tex : Textures
        Noise fields of ``grid``.
    ground_albedo : ndarray
        Output of :func:`paint_ground` for this scene's ground.

    Returns
    -------
    Layers
    """
    ground = scene.ground_height(grid.x()[None, :], grid.y()[:, None]).astype(np.float32)
    albedo = ground_albedo.copy()
    if scene.bare_soil:
        cover = np.minimum(_rect_sum(grid, scene.bare_soil), 1.0)
        albedo += cover * (_soil(tex) - albedo)
    height = ground.copy()
    normal = np.zeros((3,) + grid.shape, np.float32)
    normal[2] = 1.0
    labels = np.zeros(grid.shape, np.int32)
    layers = Layers(height, ground, albedo, normal, labels)
    for building in scene.buildings:
        _building(layers, grid, tex, scene, building)
    _cars(layers, grid, scene.cars)
    for tree in scene.trees:
        _tree(layers, grid, tex, tree.x, tree.y, tree.radius, tree.height, tree.albedo)
    return layers


def _edge_steps(edges: np.ndarray, sign: float, centres: bool) -> tuple[np.ndarray, np.ndarray]:
    """First differences of 1-D box profiles at one of their edges (grid pixel units).

    With ``centres`` the profile is the indicator of the pixel centres inside the box,
    else the exact fraction of each pixel inside it. Returns indices and values, one row
    per box.
    """
    if centres:
        index = np.ceil(edges - 0.5).astype(np.int64)
        return index[:, None], np.full((len(edges), 1), sign)
    whole = np.floor(edges)
    part = edges - whole
    index = whole.astype(np.int64)[:, None] + np.array([0, 1])
    return index, sign * np.stack([1.0 - part, part], axis=1)


def _rect_sum(grid: Grid, rects, weights=None, centres: bool = False) -> np.ndarray:
    """Sum over rectangles of ``weight * coverage`` on the grid, all boxes at once.

    A box's coverage is the outer product of two 1-D profiles, each the running sum of
    a few non-zero first differences at the box's edges; the sum over boxes is therefore
    the 2-D running sum of at most 16 scattered values per box. Exact, like
    :meth:`Grid.coverage` (``centres=False``) or :meth:`Grid.centres_in` (``centres=True``).

    Parameters
    ----------
    grid : Grid
    rects : sequence of Rect
    weights : sequence of float, optional
        Default 1 for every box.
    centres : bool
        Count pixel centres inside instead of covered area.

    Returns
    -------
    ndarray, float32
    """
    rows, cols = grid.shape
    if len(rects) == 0:
        return np.zeros(grid.shape, np.float32)
    box = np.array([(r.x0, r.y0, r.x1, r.y1) for r in rects], np.float64) / grid.gsd
    box[:, [0, 2]] += grid.col0
    box[:, [1, 3]] += grid.row0
    w = np.ones(len(rects)) if weights is None else np.asarray(weights, np.float64)
    ix0, vx0 = _edge_steps(box[:, 0], 1.0, centres)
    ix1, vx1 = _edge_steps(box[:, 2], -1.0, centres)
    iy0, vy0 = _edge_steps(box[:, 1], 1.0, centres)
    iy1, vy1 = _edge_steps(box[:, 3], -1.0, centres)
    cx, vx = np.hstack([ix0, ix1]), np.hstack([vx0, vx1])
    cy, vy = np.hstack([iy0, iy1]), np.hstack([vy0, vy1])
    n = cx.shape[1]
    r_idx = np.clip(np.repeat(cy, n, axis=1), 0, rows)
    c_idx = np.clip(np.tile(cx, (1, n)), 0, cols)
    values = np.repeat(vy, n, axis=1) * np.tile(vx, (1, n)) * w[:, None]
    deltas = np.bincount((r_idx * (cols + 1) + c_idx).ravel(), values.ravel(), (rows + 1) * (cols + 1))
    running = cv2.integral(deltas.reshape(rows + 1, cols + 1), sdepth=cv2.CV_64F)
    return running[1 : rows + 1, 1 : cols + 1].astype(np.float32)


def _half_span(b: Building) -> float:
    """Distance from a gable's ridge to its eaves (m)."""
    return 0.5 * (b.outer.height if b.ridge_along_x else b.outer.width)


def _across_ridge(b: Building, x, y):
    """Signed distance from a gable's ridge line (m)."""
    cx, cy = b.outer.centre
    return (y - cy) if b.ridge_along_x else (x - cx)


def _roof_level(b: Building, base: float, x, y):
    """Roof height at metric ``(x, y)``: flat at the eaves, or rising to a gable's ridge."""
    if b.roof != "gabled":
        return np.full(np.broadcast_shapes(np.shape(x), np.shape(y)), base + b.eave)
    return base + b.eave + b.rise * np.clip(1.0 - np.abs(_across_ridge(b, x, y)) / _half_span(b), 0.0, 1.0)


def _building(layers: Layers, grid: Grid, tex: Textures, scene: Scene, b: Building) -> None:
    """Footprint, roof height and facets, roof texture, rim, panels and boxes."""
    rows, cols = grid.window(b.outer)
    if rows.stop <= rows.start or cols.stop <= cols.start:
        return
    inside = grid.centres_in(b.outer, rows, cols)
    for hole in b.holes:
        inside &= ~grid.centres_in(hole, rows, cols)
    if not inside.any():
        return
    base = float(scene.ground_height(*b.outer.centre))
    x = grid.x()[cols][None, :]
    y = grid.y()[rows][:, None]
    roof = np.broadcast_to(_roof_level(b, base, x, y), inside.shape).astype(np.float32)
    nx = np.zeros(inside.shape, np.float32)
    ny = np.zeros(inside.shape, np.float32)
    texture = b.gravel * (0.6 * tex.fine[rows, cols] + 0.4 * tex.m05[rows, cols])
    texture = texture + 0.035 * tex.m8[rows, cols] + 0.02 * tex.m2[rows, cols]
    if b.roof == "gabled":
        across = np.broadcast_to(_across_ridge(b, x, y), inside.shape)
        slope = b.rise / _half_span(b)
        (ny if b.ridge_along_x else nx)[...] = np.sign(across) * slope
        texture = texture + 0.04 * _stripes(np.abs(across), 0.45, grid.gsd)
        texture = texture - 0.06 * (np.abs(across) < 0.3)
    albedo = b.albedo + texture
    rim = inside & ~cv2.erode(inside.astype(np.uint8), np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
    if b.roof == "flat":
        albedo = np.where(rim, albedo + 0.07, albedo)
        for panel in b.panels:
            cover = grid.coverage(panel, rows, cols)
            albedo += cover * (0.07 + 0.01 * tex.fine[rows, cols] - albedo)
    norm = np.sqrt(nx * nx + ny * ny + 1.0)
    for box in b.equipment:
        on = grid.centres_in(box.rect, rows, cols) & inside
        level = float(_roof_level(b, base, *box.rect.centre))
        roof = np.where(on, level + box.height, roof)
        albedo = np.where(on, box.albedo + 0.015 * tex.fine[rows, cols], albedo)
        nx = np.where(on, 0.0, nx)
        ny = np.where(on, 0.0, ny)
        norm = np.where(on, 1.0, norm)
    sl = (rows, cols)
    layers.height[sl] = np.where(inside, roof, layers.height[sl])
    layers.albedo[sl] = np.where(inside, albedo, layers.albedo[sl])
    layers.normal[0][sl] = np.where(inside, nx / norm, layers.normal[0][sl])
    layers.normal[1][sl] = np.where(inside, ny / norm, layers.normal[1][sl])
    layers.normal[2][sl] = np.where(inside, 1.0 / norm, layers.normal[2][sl])
    layers.labels[sl] = np.where(inside, b.id, layers.labels[sl])


#: Stretches of a car's length (fractions) and whether they are glass (windscreen, rear window).
_CAR_PARTS = ((0.0, 0.22, False), (0.22, 0.36, True), (0.36, 0.74, False), (0.74, 0.84, True), (0.84, 1.0, False))


def _cars(layers: Layers, grid: Grid, cars) -> None:
    """Car bodies (by pixel centre) with darker windscreen and rear window bands."""
    if not cars:
        return
    parts, values = [], []
    for car in cars:
        r = car.rect
        for a, b, glass in _CAR_PARTS:
            if car.along_x:
                parts.append(Rect(r.x0 + a * r.width, r.y0, r.x0 + b * r.width, r.y1))
            else:
                parts.append(Rect(r.x0, r.y0 + a * r.height, r.x1, r.y0 + b * r.height))
            values.append(0.05 if glass else car.albedo)
    body = _rect_sum(grid, [c.rect for c in cars], centres=True)
    paint = _rect_sum(grid, parts, values, centres=True)
    on = (body > 0.5) & (layers.labels == 0)
    layers.height[on] = layers.ground[on] + CAR_HEIGHT
    layers.albedo[on] = paint[on] / body[on]


def _tree(layers: Layers, grid: Grid, tex: Textures, tx: float, ty: float, radius: float, top: float, albedo: float) -> None:
    """An ellipsoidal crown with clumpy foliage; taller surfaces win."""
    rect = Rect(tx - radius, ty - radius, tx + radius, ty + radius)
    rows, cols = grid.window(rect, pad=0)
    if rows.stop <= rows.start or cols.stop <= cols.start:
        return
    dx = (grid.x()[cols][None, :] - tx) / radius
    dy = (grid.y()[rows][:, None] - ty) / radius
    rho2 = dx * dx + dy * dy
    depth = min(top - 1.5, 1.1 * radius)
    cap = np.sqrt(np.clip(1.0 - rho2, 0.0025, 1.0))
    sl = (rows, cols)
    z = layers.ground[sl] + (top - depth) + depth * cap + 0.25 * tex.m05[sl]
    on = (rho2 < 1.0) & (z > layers.height[sl])
    gx = -depth * dx / (radius * cap)
    gy = -depth * dy / (radius * cap)
    norm = np.sqrt(gx * gx + gy * gy + 1.0)
    value = albedo * (1.0 + 0.35 * tex.m05[sl] + 0.15 * tex.fine[sl])
    layers.height[sl] = np.where(on, z, layers.height[sl])
    layers.albedo[sl] = np.where(on, value, layers.albedo[sl])
    layers.normal[0][sl] = np.where(on, -gx / norm, layers.normal[0][sl])
    layers.normal[1][sl] = np.where(on, -gy / norm, layers.normal[1][sl])
    layers.normal[2][sl] = np.where(on, 1.0 / norm, layers.normal[2][sl])
