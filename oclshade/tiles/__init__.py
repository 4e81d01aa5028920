"""Maps beyond one device's (or one machine's) memory: tiles with exact halos, streamed and distributed.

:func:`cast_tiled` traces a heightmap tile by tile with the results of
:meth:`~oclshade.shadows.ShadowCaster.cast_many`; :func:`plan_tiles` and
:func:`run_jobs` are the pieces for maps that are never whole in memory
(``oclshade shadow --max-memory / --tile``, :mod:`oclshade.tiles.stream`); :func:`oclshade.tiles.dask_adapter.shadow_dask` (``pip install
'oclshade[dask]'``) returns the masks of a Dask or xarray array lazily.
Design and halo derivation: docs/scale.md.
"""
from .halo import Window, halo_window, reach_distance
from .plan import TileJob, TilePlan, auto_tile_size, plan_tiles
from .relief import ReliefGrid
from .run import TileHeightmap, Tracing, cast_tiled, run_jobs

__all__ = ["ReliefGrid", "TileHeightmap", "TileJob", "TilePlan", "Tracing", "Window", "auto_tile_size",
           "cast_tiled", "halo_window", "plan_tiles", "reach_distance", "run_jobs"]
