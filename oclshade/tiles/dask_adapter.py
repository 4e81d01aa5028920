"""Dask and xarray: shadow masks of a chunked array, returned lazily (``pip install 'oclshade[dask]'``).

:func:`shadow_dask` takes a 2-D ``dask.array`` (or numpy) array of heights, or an
``xarray.DataArray`` with ``y``/``x`` coordinates (rioxarray style: cell centres,
``y`` decreasing northward-up; the cell sizes are the coordinate steps, in metres),
and returns the masks as a lazy Dask array (a DataArray for a DataArray input),
chunked in tiles.  The graph is our own: the relief grid is computed at the call
(one reduction over the input, block max/min per chunk), then one task per tile
and group of suns reads its window (the input chunks it overlaps, no more) and
traces it; the tile's bands are sliced from that task's result.  Each worker
process builds its own OpenCL context on first use (``device``: a spec each
worker resolves, not a context); tasks of one process share it under a lock.
Results are those of :func:`oclshade.tiles.cast_tiled` (docs/scale.md).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..shadows import DEFAULT_K_BRIGHT, DEFAULT_K_DARK, ShadowResult, check_outputs
from ..sun import SunField, SunLike, as_traced
from .plan import TileJob, TilePlan, plan_tiles
from .relief import DEFAULT_BLOCK, ReliefGrid
from .run import Tracing
from .stream import check_relief

_FIELDS = {"mask": ("mask", np.uint8), "self": ("self_shadow", np.uint8), "coefficient": ("coefficient", np.float32)}


def _dask():
    try:
        import dask
        import dask.array as da
    except ImportError:
        raise ImportError("Dask is not installed: pip install 'oclshade[dask]'") from None
    return dask, da


def cell_sizes(data_array) -> tuple[float, float]:
    """(dx, dy) of a DataArray from its x/y coordinate steps; y must decrease (row 0 north)."""
    for dim in ("y", "x"):
        if dim not in data_array.coords or data_array.sizes[dim] < 2:
            raise ValueError(f"the DataArray needs a '{dim}' coordinate of at least 2 values to give its cell size "
                             f"(or pass cellsize=)")
    x, y = np.asarray(data_array["x"], np.float64), np.asarray(data_array["y"], np.float64)
    dx, dy = float(x[1] - x[0]), float(y[0] - y[1])
    if not (dx > 0.0 and dy > 0.0):
        raise ValueError(f"x must increase and y decrease along the array (row 0 north); got steps {dx:g}, {-dy:g}")
    return dx, dy


def relief_of(heights, block: int = DEFAULT_BLOCK) -> ReliefGrid:
    """The relief grid of a 2-D dask array of float64 heights (computed now, chunk by chunk)."""
    _, da = _dask()
    rows, cols = heights.shape
    aligned = tuple(tuple(_block_chunks(c, block)) for c in heights.chunks)
    if aligned != heights.chunks:
        heights = heights.rechunk(aligned)
    ext = heights.map_blocks(ReliefGrid.extrema_of, block, dtype=np.float64, new_axis=2,
                             chunks=(tuple(-(-c // block) for c in heights.chunks[0]),
                                     tuple(-(-c // block) for c in heights.chunks[1]), (2,))).compute()
    return ReliefGrid.from_extrema((rows, cols), block, ext[..., 0], ext[..., 1])


def _block_chunks(chunks: Sequence[int], block: int) -> list[int]:
    """Chunk sizes near the given ones whose boundaries fall on the block grid."""
    total, size = sum(chunks), max(block, round(max(chunks) / block) * block)
    return [min(size, total - s) for s in range(0, total, size)]


def tile_tasks(heights, suns: Sequence, dx: float, dy: float, *, method: str = "exact",
               outputs: Sequence[str] = ("mask",), k_dark: float = DEFAULT_K_DARK,
               k_bright: float = DEFAULT_K_BRIGHT, tile_size: int | None = None,
               max_window_cells: int | None = None, device: str | int | None = None,
               block: int = DEFAULT_BLOCK, relief: ReliefGrid | None = None
               ) -> tuple[TilePlan, list[tuple[TileJob, object]]]:
    """The plan of a dask array of float64 heights and, per job, a delayed list of its suns'
    cropped :class:`ShadowResult` (what :func:`shadow_dask` assembles and the CLI writes);
    ``relief``: the heights' relief grid in blocks of ``block`` where the caller has made it
    (the CLI's pass over the file), else computed here."""
    dask, _ = _dask()
    for sun in suns:
        if isinstance(sun, SunField):
            sun.check_shape(heights.shape)
    if relief is None:
        relief = relief_of(heights, block)
    check_relief(relief, dx, dy)
    tracing = Tracing(tuple(suns), method, tuple(outputs), k_dark, k_bright, dx, dy, relief.base, device)
    plan = plan_tiles(relief, tracing.suns, dx, dy, tile_size or max(heights.chunksize), max_window_cells)
    trace = dask.delayed(_trace, pure=True)
    tasks = [(job, trace(heights[job.window.r0:job.window.r1, job.window.c0:job.window.c1], job, tracing))
             for job in plan.jobs]
    return plan, tasks


def _trace(window: np.ndarray, job: TileJob, tracing: Tracing) -> list[ShadowResult]:
    return tracing.trace(job, tracing.heightmap(np.asarray(window, np.float64)))


def _pick(results: list[ShadowResult], k: int, name: str) -> np.ndarray:
    return getattr(results[k], name)


def shadow_dask(heights, suns: SunLike | SunField | Sequence[SunLike | SunField],
                cellsize: float | tuple[float, float] | None = None, *,
                method: str = "exact", output: str = "mask", k_dark: float = DEFAULT_K_DARK,
                k_bright: float = DEFAULT_K_BRIGHT, nodata: float | None = None, z_factor: float = 1.0,
                tile_size: int | None = None, device: str | int | None = None, block: int = DEFAULT_BLOCK):
    """``output`` ("mask", "self" or "coefficient") of every sun over ``heights`` (see the module
    docstring), lazily: (rows, cols) for one sun, (suns, rows, cols) for several; a DataArray
    (dims ``sun``, ``y``, ``x``, coordinates kept) for a DataArray input.  A sun may be a
    :class:`oclshade.sun.SunField` for this map (:func:`oclshade.solar.sun_field`: each block
    of cells its own sun), traced per block as :meth:`ShadowCaster.cast` does."""
    dask, da = _dask()
    (out,) = check_outputs(output)
    name, dtype = _FIELDS[out]
    sun_list = as_traced(suns)
    xarray_in = hasattr(heights, "dims") and hasattr(heights, "coords")
    if xarray_in:
        dx, dy = cell_sizes(heights) if cellsize is None else _pair(cellsize)
        data = heights.data
    else:
        if cellsize is None:
            raise ValueError("cellsize is needed for an array without coordinates (one number or (dx, dy), metres)")
        dx, dy = _pair(cellsize)
        data = heights
    arr = da.asarray(data)
    if arr.ndim != 2 or 0 in arr.shape or arr.dtype.kind not in "iuf":
        raise ValueError(f"heights must be a non-empty 2-D numeric array, got shape {arr.shape}, dtype {arr.dtype}")
    arr = arr.astype(np.float64)
    if nodata is not None and not math.isnan(nodata):
        arr = da.where(arr == nodata, np.nan, arr)
    if z_factor != 1.0:
        arr = arr * z_factor
    plan, tasks = tile_tasks(arr, sun_list, dx, dy, method=method, outputs=(out,), k_dark=k_dark,
                             k_bright=k_bright, tile_size=tile_size, device=device, block=block)
    pick = dask.delayed(_pick, pure=True)
    pieces: dict[tuple[int, int, int], object] = {}
    for job, task in tasks:
        for i, k in enumerate(job.suns):
            pieces[(k, job.tile.r0, job.tile.c0)] = da.from_delayed(pick(task, i, name), job.tile.shape, dtype)
    size = plan.tile_size
    rows, cols = arr.shape
    stacks = [da.block([[pieces[(k, r, c)] for c in range(0, cols, size)] for r in range(0, rows, size)])
              for k in range(len(sun_list))]
    result = stacks[0] if len(stacks) == 1 else da.stack(stacks)
    if not xarray_in:
        return result
    import xarray as xr
    coords = {d: heights.coords[d] for d in heights.dims}
    dims = heights.dims
    if len(stacks) > 1:
        dims = ("sun",) + tuple(dims)
        coords["sun"] = [_sun_label(s) for s in sun_list]
    return xr.DataArray(result, dims=dims, coords=coords, name=out, attrs=dict(heights.attrs))


def _sun_label(sun) -> str:
    """A sun's coordinate label; a field's from its centre sun ("field_" first)."""
    if isinstance(sun, SunField):
        return "field_" + _sun_label(sun.centre)
    return f"az{sun.azimuth:g}_alt{sun.elevation:g}"


def _pair(cellsize: float | tuple[float, float]) -> tuple[float, float]:
    if isinstance(cellsize, (tuple, list)):
        return float(cellsize[0]), float(cellsize[1])
    return float(cellsize), float(cellsize)
