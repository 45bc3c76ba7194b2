"""The inspector's panel controllers, one per panel, each owning its controls and callbacks.

- :mod:`~inspector.panels.data`: the Data tab (pairs, uploads, demo pairs, resolution);
- :mod:`~inspector.panels.tuning`: the Tune tab (presets, one folder per stage, timings);
- :mod:`~inspector.panels.view`: the View tab and the viewport (stages shown, comparing,
  overlays, clicks in the images, the 3D scene);
- :mod:`~inspector.panels.objects`: the Objects tab (table, selection, drill-down);
- :mod:`~inspector.panels.disparity`: the Disparity tab (dense matching review);
- :mod:`~inspector.panels.export`: the Export tab (rerun recordings, parameter files).

They share a :class:`~inspector.context.Context` (:class:`~inspector.panels.base.Panel`)
and reach each other only through its session and signals.
"""
