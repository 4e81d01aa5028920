"""File to file, never whole in memory: a DEM read a window at a time, masks written a tile at a time.

:func:`shadow_stream` makes one pass over the input for the :class:`ReliefGrid`
(stripes of rows; the whole map's base, float32 check and nodata-sentinel
warnings, as :class:`~oclshade.heightmap.Heightmap` does them for a map in
memory; or takes the caller's, whose extrema the CLI gives the map's places), plans the tiles within the memory budget and runs them through the
pipeline of :func:`oclshade.tiles.run_jobs`, each tile's bands going to the
writer as windows (:meth:`oclshade.io.RasterWriter.write_window`).

Memory budget: ``max_memory`` bounds the peak resident memory of the whole
process.  What the process already holds (interpreter, OpenCL runtime, compiled
kernels: measured after the kernels are built), the relief pass's stripes, two
decoded input blocks and the writer's partly filled output blocks are set
aside; the rest is divided by the bytes a window cell costs
(:func:`oclshade.tiles.plan.bytes_per_cell`, plus each job's bands held by the
pipeline) to give the largest window, and the tile size follows
(:func:`~oclshade.tiles.plan.auto_tile_size`).  Under a budget the relief pass
reads stripes of at most ``max_memory / 64`` float64 bytes (:func:`relief_stripe_bytes`),
and glibc's malloc is told to map every block of 128 KiB or more on its own
(:func:`return_freed_memory`): its default raises that threshold after each
large free, and then the arrays freed between tiles stayed in the heap (a 125 MiB
budget peaked at 141 MiB on PoCL, 200 MiB at 218 MiB on an NVIDIA H200, both
measured; docs/scale.md).
"""
from __future__ import annotations

import math
import os
import resource
import warnings
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..analysis import FRONT_BAND_BYTES
from ..heightmap import NODATA_SENTINELS, InputWarning, check_float32, ordinary_extrema, sentinels_within
from ..io import DemWindows, RasterWriter
from ..runtime import get_runtime
from ..shadows import ShadowCaster, ShadowResult
from ..sun import Sun, SunField
from .halo import Window
from .plan import TileJob, TilePlan, auto_tile_size, bytes_per_cell, plan_tiles
from .relief import DEFAULT_BLOCK, ReliefGrid
from .run import TileHeightmap, Tracing, run_jobs

RELIEF_STRIPE_BYTES = 32 << 20      # float64 bytes per stripe of the relief pass (without a budget)
RELIEF_SHARE = 64                   # under a budget: stripes of at most budget / RELIEF_SHARE bytes
SENTINEL_CHUNK_CELLS = 1 << 16      # cells per step of the nodata-sentinel count (bounds its temporaries)
MMAP_THRESHOLD = 128 << 10          # malloc blocks of this size or more get their own mapping under a budget


def relief_stripe_bytes(max_memory: int | None) -> int:
    """Float64 bytes per stripe of the relief pass: :data:`RELIEF_STRIPE_BYTES`, at most
    ``max_memory / RELIEF_SHARE`` under a budget."""
    return RELIEF_STRIPE_BYTES if max_memory is None else min(RELIEF_STRIPE_BYTES, max_memory // RELIEF_SHARE)


def return_freed_memory() -> bool:
    """Have glibc's malloc map each block of :data:`MMAP_THRESHOLD` bytes or more on its own and
    unmap it when freed (``mallopt(M_MMAP_THRESHOLD)``, which also stops the threshold from rising
    after large frees), so that a tile's arrays leave the resident set when the tile is done.
    Process-wide; True where it took effect (glibc), else False."""
    try:
        import ctypes
        libc = ctypes.CDLL(None)
        return bool(libc.mallopt(-3, MMAP_THRESHOLD))      # M_MMAP_THRESHOLD
    except (OSError, AttributeError):
        return False


def rss_bytes() -> int:
    """The process's resident memory now (Linux /proc; else its peak so far)."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return peak_rss_bytes()


def peak_rss_bytes() -> int:
    """The process's peak resident memory so far (Linux: VmHWM, which, unlike getrusage's
    ru_maxrss, does not carry a parent's peak across fork and exec)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if os.uname().sysname == "Darwin" else peak * 1024


def relief_pass(windows: DemWindows, z_factor: float = 1.0, block: int = DEFAULT_BLOCK,
                stripe_bytes: int = RELIEF_STRIPE_BYTES) -> ReliefGrid:
    """The relief grid of a windowed DEM in one pass of row stripes (at most ``stripe_bytes`` of
    float64 heights each, one row at least); warns (InputWarning) of undeclared nodata sentinels
    as :meth:`Heightmap.from_array` does."""
    rows, cols = windows.shape
    grid = ReliefGrid((rows, cols), block)
    step = max(1, min(rows, stripe_bytes // (8 * cols)))
    counts = dict.fromkeys(NODATA_SENTINELS, 0)
    ordinary = []                                      # each stripe's ordinary_extrema
    for r in range(0, rows, step):
        stripe = windows.read(r, min(r + step, rows), 0, cols)
        if z_factor != 1.0:
            stripe *= z_factor
        lo, hi = float(np.fmin.reduce(stripe, axis=None)), float(np.fmax.reduce(stripe, axis=None))
        found = sentinels_within(lo, hi)               # as Heightmap: counted only where in range
        for value, near in found:
            counts[value] += _count_near(stripe, value, near)
        ordinary.append(ordinary_extrema(stripe, lo, hi) if found else (lo, hi))
        grid.accumulate(stripe)
    lows, highs = np.array(ordinary).T
    grid.ordinary = (float(np.nanmin(lows)), float(np.nanmax(highs))) if np.any(np.isfinite(lows)) else grid.extrema
    for value, count in counts.items():
        if count:
            warnings.warn(f"heights: {count} cell(s) equal {value:.8g}, a common nodata value, but it is not "
                          f"declared as nodata; if those cells are holes, declare it (--nodata {value:.8g} "
                          f"or nodata={value:.8g})", InputWarning, stacklevel=2)
    return grid


def _count_near(stripe: np.ndarray, value: float, near: float) -> int:
    """Cells with |height - value| <= near, :data:`SENTINEL_CHUNK_CELLS` at a time."""
    flat = stripe.reshape(-1)
    return sum(int(np.count_nonzero(np.abs(flat[i:i + SENTINEL_CHUNK_CELLS] - value) <= near))
               for i in range(0, flat.size, SENTINEL_CHUNK_CELLS))


def check_relief(grid: ReliefGrid, dx: float, dy: float) -> None:
    """Refuse heights the float32 kernels cannot hold, as Heightmap does for a map in memory."""
    lo, hi = grid.extrema
    if not math.isnan(lo):
        try:
            check_float32(np.array([lo, hi]), lo, hi, dx, dy)
        except ValueError as exc:
            raise ValueError(str(exc).split(": 1 cell(s)")[0] + "; if the extreme is a nodata value, declare it "
                             "(--nodata VALUE or nodata=)") from None


@dataclass
class StreamRun:
    """What :func:`shadow_stream` did."""

    plan: TilePlan
    relief: ReliefGrid
    max_window_cells: int | None
    baseline_bytes: int              # resident memory before the tiles (runtime and kernels built)


def window_cell_bytes(outputs: Sequence[str], bands_per_job: int, itemsize: int) -> int:
    """Resident bytes per window cell: the tracing (:func:`~oclshade.tiles.plan.bytes_per_cell`)
    and each job's output bands, twice (one job's being written while the next is traced)."""
    return bytes_per_cell(outputs) + 2 * bands_per_job * itemsize


def memory_plan(budget: int, baseline: int, cols: int, segment_bytes: int, bands_per_job: int, itemsize: int,
                outputs: Sequence[str], out_block: int) -> int:
    """The largest window (cells) a budget of ``budget`` bytes of resident memory allows (see the
    module docstring); raises ValueError naming what does not fit."""
    stripe = max(relief_stripe_bytes(budget), 8 * cols)          # float64; the file's dtype beside it
    reserved = baseline + 2 * stripe + 2 * segment_bytes + out_block * cols * bands_per_job * itemsize + \
        FRONT_BAND_BYTES                                          # the scene analysis of a window
    per_cell = window_cell_bytes(outputs, bands_per_job, itemsize)
    cells = (budget - reserved) // per_cell
    if cells < 64 * 64:
        raise ValueError(f"a memory budget of {budget / 2**20:.0f} MiB leaves no room for a tile: the process holds "
                         f"{baseline / 2**20:.0f} MiB before any tile, the reads and the output's block row "
                         f"{(reserved - baseline) / 2**20:.0f} MiB, and a window cell costs {per_cell} bytes")
    return int(cells)


def shadow_stream(windows: DemWindows, writer: RasterWriter, suns: Sequence[Sun], *,
                  bands: Callable[[ShadowResult], list[np.ndarray]], dx: float, dy: float, z_factor: float = 1.0,
                  method: str = "exact", outputs: Sequence[str] = ("mask",), k_dark: float = 0.25,
                  k_bright: float = 0.65, tile_size: int | None = None, max_memory: int | None = None,
                  device=None, overlap: bool = True, out_block: int = 512,
                  progress: Callable[[int, int], None] | None = None,
                  relief: ReliefGrid | None = None) -> StreamRun:
    """Shadows of a windowed DEM into a writer, tile by tile (see the module docstring).
    ``bands(result)``: a sun's output bands (written as bands k * n .. k * n + n - 1 for sun
    k); ``outputs``: what the tiles compute; ``out_block``: the output's block height (its
    partly filled blocks are budgeted); ``relief``: the map's :func:`relief_pass` at this
    ``z_factor`` where the caller has made it (else made here)."""
    rt = get_runtime(device)
    if max_memory is not None:
        return_freed_memory()
    if relief is None:
        relief = relief_pass(windows, z_factor, stripe_bytes=relief_stripe_bytes(max_memory))
    check_relief(relief, dx, dy)
    base = relief.base
    tracing = Tracing(tuple(suns), method, tuple(outputs), k_dark, k_bright, dx, dy, base, rt)
    first = suns[0].centre if isinstance(suns[0], SunField) else suns[0]
    per_sun = len(bands(_blank_result(first, tracing.outputs)))
    probe = TileHeightmap(np.zeros((2, 2)), dx, dy, 0.0)
    ShadowCaster(probe, rt, cache=False).warm_up(method, tracing.outputs)   # kernels built before the baseline
    baseline = rss_bytes()
    rows, cols = relief.shape
    cells = None
    if max_memory is not None:
        itemsize = writer.dtype.itemsize
        cells = memory_plan(max_memory, baseline, cols, windows.segment_bytes, len(suns) * per_sun, itemsize,
                            tracing.outputs, out_block)
    size = tile_size or auto_tile_size(relief, suns, dx, dy, cells or 4096 * 4096)
    plan = plan_tiles(relief, suns, dx, dy, size, cells)
    if cells is not None and plan.largest_window > cells:
        per_cell = window_cell_bytes(tracing.outputs, len(suns) * per_sun, writer.dtype.itemsize)
        need = max_memory + (plan.largest_window - cells) * per_cell
        raise ValueError(f"a memory budget of {max_memory / 2**20:.0f} MiB allows windows of {cells} cells, but tiles "
                         f"of {plan.tile_size} cells a side read up to {plan.largest_window} with the halo their suns' "
                         f"shadows need: give at least {math.ceil(need / 2**20)} MiB")

    def read(window: Window) -> np.ndarray:
        heights = windows.read(window.r0, window.r1, window.c0, window.c1)
        if z_factor != 1.0:
            heights *= z_factor
        return heights

    def write(job: TileJob, results: list[ShadowResult]) -> None:
        for k, res in zip(job.suns, results):
            for i, band in enumerate(bands(res)):
                writer.write_window(k * per_sun + i, job.tile.r0, job.tile.c0, band)

    run_jobs(plan.jobs, read, write, tracing, overlap=overlap, progress=progress)
    return StreamRun(plan, relief, cells, baseline)


def _blank_result(sun: Sun, outputs: tuple[str, ...]) -> ShadowResult:
    one = np.zeros((1, 1), np.uint8)
    return ShadowResult(sun, one if "mask" in outputs else None, one if "self" in outputs else None,
                        np.ones((1, 1), np.float32) if "coefficient" in outputs else None)
