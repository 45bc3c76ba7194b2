"""Scene mode: whole satellite scenes processed tile by tile on Dask with bounded memory.

- :mod:`radcons.scene.source`: windowed reading of the pair (never a whole image in memory);
- :mod:`radcons.scene.levelling`: the target's vertical offset taken out window by window;
- :mod:`radcons.scene.stats`: pixel statistics, histograms and sigma_max streamed over blocks;
- :mod:`radcons.scene.pairwide`: objects from a decimated copy, and what fitting them needs;
- :mod:`radcons.scene.features`, :mod:`radcons.scene.window_association`: the objects'
  association at full resolution;
- :mod:`radcons.scene.object_fits`: each object's fit (eq 7-12) on a window around it;
- :mod:`radcons.scene.pass1`: every pair-wide quantity the tiles need;
- :mod:`radcons.scene.tiles`: the image stages on one tile with a halo;
- :mod:`radcons.scene.writer`: tiled GeoTIFFs written tile by tile, swapped in whole;
- :mod:`radcons.scene.cluster`: the Dask cluster (local or an existing scheduler);
- :mod:`radcons.scene.run`: :func:`run_scene`, the entry point.
"""

from radcons.scene.run import (
    DEFAULT_TILE,
    SceneOptions,
    SceneResult,
    run_scene,
    scene_stages,
)
from radcons.scene.source import ScenePair, open_scene_pair

__all__ = ["run_scene", "SceneOptions", "SceneResult", "scene_stages", "ScenePair", "open_scene_pair", "DEFAULT_TILE"]
