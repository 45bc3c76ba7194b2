"""The inspector's panels and controls (created once per server, shared by every client).

No control carries an icon: viser reads each icon from a zip archive of several thousand
files when it is added (about 0.1 s apiece), which would add seconds to the start.

Left: the control panel with a status line and the tabs *Data*, *Tune*, *View* and
*Export*. Right: a panel with the tabs *Objects* (table and drill-down) and *Disparity*
(dense matching review). The middle is the viewport (see :mod:`inspector.views`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from inspector.views import COMPARE_MODES
from inspector.widgets import StageControls

__all__ = ["Layout", "build_layout", "OVERLAYS", "SCENARIOS", "SMOOTHNESS_MODES", "LEFT_WIDTH", "RIGHT_WIDTH"]

#: Widths, CSS px, of the control panel (left) and the objects panel (right).
LEFT_WIDTH = 360
RIGHT_WIDTH = 470

#: Overlay checkboxes: label -> shown by default.
OVERLAYS: dict[str, bool] = {
    "Object outlines": True,
    "Object ids": True,
    "SIFT matches": False,
    "Invariant points": False,
    "Change mask": False,
}
#: When the smoothness stage runs during tuning.
SMOOTHNESS_MODES: tuple[str, ...] = ("on request", "after each change")
#: Demo generator scenarios (what differs between the two images).
SCENARIOS: tuple[str, ...] = ("mixed", "multi-temporal", "multi-sensor", "none")
_BLANK = np.full((8, 8, 3), 28, np.uint8)


@dataclass
class Layout:
    """Handles of every control the app reads or updates."""

    status: Any
    progress: Any
    # Data
    pair_info: Any
    pair: Any
    folder: Any
    open_folder: Any
    upload_reference: Any
    upload_target: Any
    upload_info: Any
    scenario: Any
    seed: Any
    demo_size: Any
    generate: Any
    work_mode: Any
    apply_full: Any
    # Tune
    preset: Any = None
    stages: dict[str, StageControls] = field(default_factory=dict)
    smoothness_mode: Any = None
    fast_smoothness: Any = None
    run_smoothness: Any = None
    reset_all: Any = None
    timings: Any = None
    # View
    view: Any = None
    compare: Any = None
    swipe: Any = None
    overlays: dict[str, Any] = field(default_factory=dict)
    height_scale: Any = None
    # Export
    record: Any = None
    export: Any = None
    export_info: Any = None
    # Objects panel
    object_choice: Any = None
    object_table: Any = None
    object_metrics: Any = None
    object_crops: Any = None
    object_histograms: Any = None
    object_fit: Any = None
    # Disparity panel
    auto_review: Any = None
    review_now: Any = None
    review_table: Any = None
    disparity_image: Any = None
    truth_image: Any = None
    error_image: Any = None


def build_layout(
    server: Any,
    params: Any,
    presets: Sequence[str],
    stages: Sequence[str],
    switchable: frozenset[str],
    views: Sequence[str],
    initial_view: str,
    on_change: Any,
    on_reset: Any,
    max_upload_mib: int,
) -> Layout:
    """Create every panel and control; callbacks are attached by the app afterwards.

    Parameters
    ----------
    server : viser.ViserServer
    params : radcons.params.Params
        Initial parameters, those of a preset (the controls start at these values, and
        each stage's reset button restores them).
    presets : sequence of str
        Names of the presets.
    stages : sequence of str
        Stage names in pipeline order (one folder each).
    switchable : frozenset of str
        Stages that get an ``enabled`` checkbox.
    views : sequence of str
        Options of the stage-to-show dropdown.
    initial_view : str
        The stage shown first.
    on_change, on_reset : callable
        Passed to each :class:`StageControls`.
    max_upload_mib : int
        Upload size limit shown to the user.
    """
    gui = server.gui
    gui.configure_theme(dark_mode=True, control_width="large", show_share_button=False, brand_color=(64, 156, 255))
    gui.main_panel.dock_left()
    gui.main_panel.set_width(LEFT_WIDTH)

    status = gui.add_markdown("**radcons inspector** — starting…")
    progress = gui.add_progress_bar(0.0, animated=False)
    tabs = gui.add_tab_group()

    with tabs.add_tab("Data"):
        pair_info = gui.add_markdown("")
        pair = gui.add_dropdown("Pair", ("built-in demo",), initial_value="built-in demo", hint="Pairs given on the command line and found under --data-root")
        folder = gui.add_text("Folder", "", hint="A pair folder (with pair.toml) inside the allowed folders")
        open_folder = gui.add_button("Open folder")
        with gui.add_folder("Upload two images", expand_by_default=False):
            gui.add_markdown(f"PNG or TIFF, single band, up to {max_upload_mib} MiB each; reference (left) first.")
            upload_reference = gui.add_upload_button("Reference image", mime_type="image/png,image/tiff,.tif,.tiff,.png")
            upload_target = gui.add_upload_button("Target image", mime_type="image/png,image/tiff,.tif,.tiff,.png")
            upload_info = gui.add_markdown("")
        with gui.add_folder("Demo generator", expand_by_default=False):
            scenario = gui.add_dropdown("Scenario", SCENARIOS, initial_value="mixed")
            seed = gui.add_number("Seed", 0, min=0, step=1)
            demo_size = gui.add_number("Size", 512, min=64, max=4096, step=64)
            generate = gui.add_button("Generate demo pair")
        with gui.add_folder("Resolution"):
            work_mode = gui.add_dropdown(
                "Tune on", ("preview", "full", "region"), initial_value="preview",
                hint="preview: the whole pair downsampled; full: every pixel; region: a full-resolution window (Shift+click the image to move it)",
            )
            apply_full = gui.add_button("Apply to full resolution")

    layout = Layout(
        status, progress, pair_info, pair, folder, open_folder, upload_reference, upload_target, upload_info,
        scenario, seed, demo_size, generate, work_mode, apply_full,
    )

    with tabs.add_tab("Tune"):
        layout.preset = gui.add_dropdown(
            "Preset", tuple(presets), initial_value=params.preset,
            hint="paper: the paper's method and values; radcons: the measured improvements (changing it resets every stage)",
        )
        layout.timings = gui.add_markdown("")
        for stage in stages:
            with gui.add_folder(stage, expand_by_default=False):
                if stage == "smoothness":
                    layout.smoothness_mode = gui.add_dropdown(
                        "runs", SMOOTHNESS_MODES, initial_value=SMOOTHNESS_MODES[0],
                        hint="Union group sparse denoising is slow: run it when asked, or after every change",
                    )
                    layout.fast_smoothness = gui.add_checkbox(
                        "fast on previews", True,
                        hint="On a downsampled preview or a region, half the similar patches and a "
                        "15 px search window (a 512 px pair in under 2 s); full resolution runs "
                        "the values below",
                    )
                    layout.run_smoothness = gui.add_button("Run smoothness now")
                layout.stages[stage] = StageControls(
                    gui, stage, params.stage(stage), params.enabled(stage) if stage in switchable else None,
                    params.stage(stage), on_change, on_reset,
                )
        layout.reset_all = gui.add_button("Reset every stage")

    with tabs.add_tab("View"):
        layout.view = gui.add_dropdown("Stage", tuple(views), initial_value=initial_view)
        layout.compare = gui.add_dropdown("Compare", COMPARE_MODES, initial_value=COMPARE_MODES[0])
        layout.swipe = gui.add_slider("Swipe", min=0.0, max=1.0, step=0.01, initial_value=0.5)
        with gui.add_folder("Overlays"):
            for label, default in OVERLAYS.items():
                layout.overlays[label] = gui.add_checkbox(label, default)
        layout.height_scale = gui.add_slider("3D height scale", min=0.5, max=20.0, step=0.5, initial_value=4.0)
        gui.add_markdown(
            "Images of a pair share one grey-value range, so their radiometric difference stays "
            "visible. Click an object to inspect it."
        )

    with tabs.add_tab("Export"):
        layout.record = gui.add_button("Record to rerun", hint="Write the current run and every setting tried to an .rrd")
        layout.export = gui.add_button("Export parameters", hint="Write the TOML that `radcons process --params` reads")
        layout.export_info = gui.add_markdown("")

    side = gui.add_panel()
    with side.add_tab("Objects"):
        layout.object_choice = gui.add_dropdown("Object", ("none",), initial_value="none")
        layout.object_metrics = gui.add_markdown("Click an object in the images, or choose it above.")
        layout.object_crops = gui.add_image(_BLANK, label="reference | target (current stage)", format="jpeg", visible=False)
        layout.object_histograms = gui.add_image(_BLANK, label="grey-value histograms", format="png", visible=False)
        layout.object_fit = gui.add_image(_BLANK, label="invariant points and fitted line (eq 8)", format="png", visible=False)
        layout.object_table = gui.add_markdown("")
    with side.add_tab("Disparity"):
        layout.auto_review = gui.add_checkbox("Match after each run", True, hint="Dense matching (SGBM) of the shown stage after every run")
        layout.review_now = gui.add_button("Match now")
        layout.review_table = gui.add_markdown("")
        layout.disparity_image = gui.add_image(_BLANK, label="disparity (shown stage)", format="jpeg")
        layout.truth_image = gui.add_image(_BLANK, label="ground truth", format="jpeg")
        layout.error_image = gui.add_image(_BLANK, label="error: green < 1 px, red wrong, blue failed", format="png")
    side.dock_right()
    side.set_width(RIGHT_WIDTH)
    return layout
