"""Tiling a map: the tiles, the windows of heights each reads, and what they cost in memory.

A :class:`TileJob` writes the results of one tile (``tile``, a square of
``tile_size`` cells, cut at the map's edges) for some of the suns, from the
heights of ``window``: the tile grown by the halo of each of those suns
(:mod:`oclshade.tiles.halo`), clipped to the map and with its origin moved down
to a multiple of :data:`ALIGN` cells.  The alignment keeps the pyramid texels
(levels up to log2 ALIGN) and the certificate tiles of the window on the same
cells as the whole map's; results do not depend on it (the pyramid only prunes).

Suns are grouped per tile, in azimuth order, while the union of their windows
stays within ``max_window_cells``: one window (one read, one pyramid) serves a
group, so many suns from one side cost one read.  Memory per window cell is
:func:`bytes_per_cell`.

A sun may be a :class:`oclshade.sun.SunField` (each block of cells its own sun): its halo
for a tile is the union of each block's, the part of the tile in the block grown by the
halo of the block's sun (:func:`sun_halo`), so every block's rays find their terrain.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from ..sun import Sun, SunField
from .halo import HEIGHT_MARGIN_ABSOLUTE, HEIGHT_MARGIN_RELATIVE, RAY_CELLS_MARGIN, Window, halo_window
from .relief import ReliefGrid

ALIGN = 64
TILE_SIZES = (8192, 4096, 2048, 1024, 512, 256, 128, 64)   # candidates of auto_tile_size, largest first
#: bytes per window cell while a tile is traced: float64 heights (8), float32 relative heights on the host
#: and the device (4 + 4), the extrema pyramid (8 / 3), the next tile's heights read meanwhile (8 + 4 + the
#: file's 4), rounded up
HEIGHT_BYTES = 36
#: bytes per output band per window cell: on the device and on the host (results are cropped after)
OUTPUT_BYTES = {"mask": 2, "self": 2, "coefficient": 8}


def bytes_per_cell(outputs: Sequence[str]) -> int:
    """Memory per window cell of one traced tile (see the constants above; the mask is always
    computed, and the suns of a window are traced one at a time)."""
    outs = set(outputs) | {"mask"}
    return HEIGHT_BYTES + sum(OUTPUT_BYTES[o] for o in outs)


@dataclass(frozen=True)
class TileJob:
    tile: Window                 # the cells whose results this job gives
    window: Window               # the heights it reads
    suns: tuple[int, ...]        # indices into the plan's suns


@dataclass(frozen=True)
class TilePlan:
    shape: tuple[int, int]
    tile_size: int
    suns: tuple[Sun | SunField, ...]
    jobs: tuple[TileJob, ...]

    @property
    def largest_window(self) -> int:
        return max(job.window.cells for job in self.jobs)

    @property
    def cells_read(self) -> int:
        """Heights read in all (each job reads its window once)."""
        return sum(job.window.cells for job in self.jobs)

    @property
    def trace_overhead(self) -> float:
        """Cells traced per result cell, minus 1: each sun of a job traces its whole window
        (0 would be no halo at all)."""
        rows, cols = self.shape
        return sum(job.window.cells * len(job.suns) for job in self.jobs) / (rows * cols * len(self.suns)) - 1.0


def tiles_of(shape: tuple[int, int], size: int) -> list[Window]:
    """The ``size`` x ``size`` tiles of a map in row-major order (cut at its edges)."""
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        raise ValueError(f"tile size must be a positive integer (cells), got {size!r}")
    rows, cols = shape
    return [Window(r, min(r + size, rows), c, min(c + size, cols))
            for r in range(0, rows, size) for c in range(0, cols, size)]


def sun_halo(relief: ReliefGrid, tile: Window, sun: Sun | SunField, dx: float, dy: float) -> Window:
    """:func:`halo_window` of a sun, or of a sun field: the union over its blocks of the part of
    the tile in the block grown by the halo of the block's sun."""
    if not isinstance(sun, SunField):
        return halo_window(relief, tile, sun, dx, dy)
    window = None
    for block in sun.blocks:
        part = Window(max(tile.r0, block.row0), min(tile.r1, block.row1), max(tile.c0, block.col0),
                      min(tile.c1, block.col1))
        if part.r0 < part.r1 and part.c0 < part.c1:
            mine = halo_window(relief, part, block.sun, dx, dy)
            window = mine if window is None else window.union(mine)
    return window if window is not None else tile


def _lowest_sun(sun: Sun | SunField) -> Sun:
    """A sun, or a field's block sun of the lowest positive elevation (the longest halo)."""
    if not isinstance(sun, SunField):
        return sun
    up = [b.sun for b in sun.blocks if b.sun.elevation > 0.0]
    return min(up, key=lambda s: s.elevation) if up else sun.centre


def plan_tiles(relief: ReliefGrid, suns: Sequence[Sun | SunField], dx: float, dy: float, tile_size: int,
               max_window_cells: int | None = None, align: int = ALIGN) -> TilePlan:
    """The jobs of a tiled run (see the module docstring), tiles in row-major order, window
    origins moved down to multiples of ``align``.  A sun whose window alone exceeds
    ``max_window_cells`` still gets a job of its own (the caller decides)."""
    if isinstance(align, bool) or not isinstance(align, int) or align < 1:
        raise ValueError(f"align must be a positive integer (cells), got {align!r}")
    suns = tuple(suns)

    def aligned(w: Window) -> Window:
        return Window(w.r0 // align * align, w.r1, w.c0 // align * align, w.c1)

    def key(k: int) -> tuple[float, float]:
        sun = suns[k].centre if isinstance(suns[k], SunField) else suns[k]
        return sun.azimuth % 360.0, sun.elevation

    order = sorted(range(len(suns)), key=key)
    jobs = []
    for tile in tiles_of(relief.shape, tile_size):
        group: list[int] = []
        window: Window | None = None
        for k in order:
            mine = aligned(sun_halo(relief, tile, suns[k], dx, dy))
            grown = mine if window is None else window.union(mine)
            if group and max_window_cells is not None and grown.cells > max_window_cells:
                jobs.append(TileJob(tile, window, tuple(sorted(group))))
                group, grown = [], mine
            group.append(k)
            window = grown
        jobs.append(TileJob(tile, window, tuple(sorted(group))))
    return TilePlan(tuple(relief.shape), tile_size, suns, tuple(jobs))


def halo_bound(relief: ReliefGrid, sun: Sun, dx: float, dy: float) -> tuple[int, int]:
    """Upper bounds of a halo (rows, cols) for ``sun`` over the whole map: the map's relief over
    tan(elevation), capped by the map (what :func:`auto_tile_size` sizes tiles with)."""
    rows, cols = relief.shape
    if sun.below_horizon or sun.at_zenith:
        return 1, 1
    lo, hi = relief.extrema
    ux, uy, w = sun.ray(dx, dy)
    if math.isnan(lo):
        return 1, 1
    t = math.inf if w <= 0.0 else (hi - lo + HEIGHT_MARGIN_RELATIVE * (hi - lo) + HEIGHT_MARGIN_ABSOLUTE) / w
    extra = relief.block + RAY_CELLS_MARGIN + ALIGN          # the march's last block, the margin, the alignment

    def cells(u: float, n: int) -> int:
        return 1 if u == 0.0 else min(n, int(min(abs(u) * t, n)) + extra)

    return cells(uy, rows), cells(ux, cols)


def auto_tile_size(relief: ReliefGrid, suns: Sequence[Sun | SunField], dx: float, dy: float,
                   max_window_cells: int) -> int:
    """The largest of :data:`TILE_SIZES` whose windows (tile + :func:`halo_bound`) fit in
    ``max_window_cells`` for every sun alone (a field: its lowest block sun); the smallest when
    none does."""
    rows, cols = relief.shape
    halos = [halo_bound(relief, _lowest_sun(sun), dx, dy) for sun in suns]
    for size in TILE_SIZES:
        if all(min(size + hr + 1, rows) * min(size + hc + 1, cols) <= max_window_cells for hr, hc in halos):
            return size
    return TILE_SIZES[-1]
