"""``oclshade shadow --workers N``: a file traced on a local ``distributed`` cluster of N processes.

Each worker reads its chunks of the input itself (:func:`oclshade.io.open_dem`
in the worker), traces tiles with its own OpenCL context
(:mod:`oclshade.tiles.dask_adapter`) and sends back only the tile's bands; this
process writes them as they complete.  For a real cluster see docs/scale.md.
"""
from __future__ import annotations

import argparse
from typing import Callable, Sequence

import numpy as np

from ..io import DemWindows, RasterWriter, open_dem
from ..shadows import ShadowResult
from .dask_adapter import _dask, tile_tasks
from .plan import TilePlan
from .relief import ReliefGrid

DEFAULT_CHUNK = 1024


def _read_window(path: str, cellsize, band, nodata, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    with open_dem(path, cellsize, band, nodata) as windows:
        return windows.read(r0, r1, c0, c1)


def file_array(path: str, shape: tuple[int, int], chunk: int, cellsize=None, band: int | None = None,
               nodata: float | None = None, z_factor: float = 1.0):
    """The heights of a DEM file as a dask array of ``chunk``-square chunks, each read by the task
    that needs it (float64, nodata NaN, times ``z_factor``)."""
    dask, da = _dask()
    read = dask.delayed(_read_window, pure=True)
    rows, cols = shape
    arr = da.block([[da.from_delayed(read(path, cellsize, band, nodata, r, min(r + chunk, rows), c,
                                          min(c + chunk, cols)),
                                     (min(r + chunk, rows) - r, min(c + chunk, cols) - c), np.float64)
                     for c in range(0, cols, chunk)] for r in range(0, rows, chunk)])
    return arr * z_factor if z_factor != 1.0 else arr


def shadow_file_workers(args: argparse.Namespace, windows: DemWindows, out: RasterWriter, suns: Sequence,
                        bands: Callable[[ShadowResult], list[np.ndarray]], dx: float, dy: float, workers: int,
                        tile_size: int | None, progress: Callable[[int, int], None] | None,
                        relief: ReliefGrid | None = None, **tracing) -> TilePlan:
    """Trace ``args.input`` on ``workers`` local processes into ``out`` (see the module docstring);
    ``relief``: the input's relief grid where the caller has made it (else the graph makes it)."""
    from distributed import Client, LocalCluster, as_completed

    chunk = tile_size or DEFAULT_CHUNK
    cell = (windows.raster.dx, windows.raster.dy) if args.cellsize else None
    arr = file_array(args.input, windows.shape, chunk, cell, args.band, args.nodata, args.z_factor)
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        plan, tasks = tile_tasks(arr, suns, dx, dy, tile_size=chunk, device=args.device, relief=relief, **tracing)
        futures = client.compute([task for _, task in tasks])
        job_of = {future.key: job for future, (job, _) in zip(futures, tasks)}
        per_sun = None
        for k, future in enumerate(as_completed(futures)):
            job = job_of[future.key]
            for s, res in zip(job.suns, future.result()):
                sun_bands = bands(res)
                per_sun = per_sun or len(sun_bands)
                for i, band in enumerate(sun_bands):
                    out.write_window(s * per_sun + i, job.tile.r0, job.tile.c0, band)
            future.release()
            if progress is not None:
                progress(k + 1, len(futures))
    return plan
