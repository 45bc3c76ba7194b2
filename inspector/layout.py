"""Where the inspector's panels go (created once per server, shared by every client).

Left: the control panel with a status line and the tabs *Data*, *Tune*, *View* and
*Export*. Right: a panel with the tabs *Objects* (table and drill-down) and *Disparity*
(dense matching review). The middle is the viewport (see :mod:`inspector.viewport`).
Each tab's controls are built by its panel controller (:mod:`inspector.panels`).

The viewport's pictures (reference, target and the review's disparity map) are laid out
in a grid chosen for the canvas's shape (:func:`grid_shape`): two square images stand side
by side in a wide canvas and one above the other in a tall one, so that each is drawn as
large as the canvas allows. :func:`grid_centres` places them (:class:`ImagePlacement`) and
:func:`fit_scale` gives how many canvas pixels a scene unit spans once the camera frames
the grid.

No control carries an icon: viser reads each icon from a zip archive of several thousand
files when it is added (about 0.1 s apiece), which would add seconds to the start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

__all__ = ["build_layout", "BLANK", "LEFT_WIDTH", "RIGHT_WIDTH", "GAP", "TITLE", "MARGIN", "grid_shape", "grid_extent", "grid_centres", "fit_scale", "ImagePlacement", "picture_size"]

#: Widths, CSS px, of the control panel (left) and the objects panel (right).
LEFT_WIDTH = 360
RIGHT_WIDTH = 470
#: Placeholder of a picture not drawn yet.
BLANK = np.full((8, 8, 3), 28, np.uint8)

Builder = Callable[[Any], None]

#: Scene units between two pictures of the grid, and above each for its title (a label
#: of fixed screen size: about 14 px high on a 500 px picture).
GAP = 0.02
TITLE = 0.035
#: The framed grid spans 1 / MARGIN of the canvas along its tighter side.
MARGIN = 1.02


@dataclass(frozen=True)
class ImagePlacement:
    """Where one displayed picture lies in the scene.

    Attributes
    ----------
    centre : (float, float)
        Scene x, y of the picture centre.
    size : (float, float)
        Scene width and height.
    shape : (int, int)
        ``(height, width)``, work-pair pixels, of the part of the pair it shows.
    origin : (int, int)
        Work-pair pixel ``(x, y)`` of its top-left corner (the pair may be cropped to its
        valid pixels, :class:`render.DisplayFrame`).
    """

    centre: tuple[float, float]
    size: tuple[float, float]
    shape: tuple[int, int]
    origin: tuple[int, int] = (0, 0)

    def pixel(self, point: np.ndarray) -> tuple[float, float] | None:
        """Work-pair pixel ``(x, y)`` under scene ``point``, or None when outside."""
        u = (point[0] - (self.centre[0] - self.size[0] / 2)) / self.size[0]
        v = (point[1] - (self.centre[1] - self.size[1] / 2)) / self.size[1]
        if not (0.0 <= u < 1.0 and 0.0 <= v < 1.0):
            return None
        return self.origin[0] + u * self.shape[1], self.origin[1] + v * self.shape[0]


def picture_size(shape: tuple[int, int]) -> tuple[float, float]:
    """Scene width and height of a picture of ``shape``: its longest side is one unit."""
    side = max(shape)
    return shape[1] / side, shape[0] / side


def grid_extent(columns: int, rows: int, size: tuple[float, float]) -> tuple[float, float]:
    """Scene width and height of a grid of pictures of ``size`` (with gaps and title bands)."""
    return columns * size[0] + (columns - 1) * GAP, rows * (size[1] + TITLE) + (rows - 1) * GAP


def fit_scale(extent: tuple[float, float], canvas: tuple[float, float]) -> float:
    """Canvas pixels per scene unit when a camera frames ``extent`` in ``canvas``.

    The extent is fitted whole, :data:`MARGIN` times smaller than the canvas along the
    side that limits it (the other side keeps the spare room).

    Parameters
    ----------
    extent : (float, float)
        Scene width and height to show.
    canvas : (float, float)
        Canvas width and height, pixels.
    """
    return min(canvas[0] / extent[0], canvas[1] / extent[1]) / MARGIN


def grid_shape(count: int, size: tuple[float, float], canvas: tuple[float, float]) -> tuple[int, int]:
    """``(columns, rows)`` of the grid that draws ``count`` pictures of ``size`` largest in ``canvas``.

    Every arrangement without an empty row is tried (1 to ``count`` columns); the one
    whose framing (:func:`fit_scale`) gives the most canvas pixels per scene unit wins,
    and of equal ones the one with fewer rows (side by side reads like a stereo pair).

    Parameters
    ----------
    count : int
        Number of pictures (all of one size).
    size : (float, float)
        Scene width and height of one picture.
    canvas : (float, float)
        Canvas width and height, pixels (only their ratio matters).
    """
    best: tuple[float, int, int] | None = None
    for columns in range(max(count, 1), 0, -1):
        rows = math.ceil(count / columns)
        scale = fit_scale(grid_extent(columns, rows, size), canvas)
        if best is None or scale > best[0] * (1 + 1e-9):
            best = (scale, columns, rows)
    return best[1], best[2]


def grid_centres(count: int, columns: int, size: tuple[float, float]) -> list[tuple[float, float]]:
    """Scene centres of ``count`` pictures of ``size`` filled row by row into ``columns``.

    The grid (titles included) is centred on the scene origin; scene y grows downwards,
    as image rows do, and each picture's title band lies above it.
    """
    rows = math.ceil(count / columns)
    width, height = grid_extent(columns, rows, size)
    centres = []
    for index in range(count):
        row, column = divmod(index, columns)
        x = -width / 2 + column * (size[0] + GAP) + size[0] / 2
        y = -height / 2 + row * (size[1] + TITLE + GAP) + TITLE + size[1] / 2
        centres.append((x, y))
    return centres


def build_layout(server: Any, header: Builder, left: Mapping[str, Builder], right: Mapping[str, Builder]) -> None:
    """Theme the page, dock the two panels and build every tab.

    Parameters
    ----------
    server : viser.ViserServer
    header : callable
        ``header(gui)`` adds what stays above the left tabs (the status line).
    left, right : mapping
        Tab title -> ``build(gui)`` adding that tab's controls, in order, for the left
        (control) and the right (objects) panel.
    """
    gui = server.gui
    gui.configure_theme(dark_mode=True, control_width="large", show_share_button=False, brand_color=(64, 156, 255))
    gui.main_panel.dock_left()
    gui.main_panel.set_width(LEFT_WIDTH)
    header(gui)
    tabs = gui.add_tab_group()
    for title, build in left.items():
        with tabs.add_tab(title):
            build(gui)
    side = gui.add_panel()
    for title, build in right.items():
        with side.add_tab(title):
            build(gui)
    side.dock_right()
    side.set_width(RIGHT_WIDTH)
