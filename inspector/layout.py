"""Where the inspector's panels go (created once per server, shared by every client).

Left: the control panel with a status line and the tabs *Data*, *Tune*, *View* and
*Export*. Right: a panel with the tabs *Objects* (table and drill-down) and *Disparity*
(dense matching review). The middle is the viewport (see :mod:`inspector.viewport`).
Each tab's controls are built by its panel controller (:mod:`inspector.panels`).

No control carries an icon: viser reads each icon from a zip archive of several thousand
files when it is added (about 0.1 s apiece), which would add seconds to the start.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

__all__ = ["build_layout", "BLANK", "LEFT_WIDTH", "RIGHT_WIDTH"]

#: Widths, CSS px, of the control panel (left) and the objects panel (right).
LEFT_WIDTH = 360
RIGHT_WIDTH = 470
#: Placeholder of a picture not drawn yet.
BLANK = np.full((8, 8, 3), 28, np.uint8)

Builder = Callable[[Any], None]


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
