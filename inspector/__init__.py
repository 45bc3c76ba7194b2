"""The radcons inspector: a browser app (viser) to load stereo pairs, inspect their objects
and tune every stage of the method live. It calls :mod:`radcons` for every result.

Start it with ``radcons inspect [PAIR ...]`` or :class:`inspector.app.InspectorApp`.
"""
