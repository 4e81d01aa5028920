"""The relief of a whole map in blocks: the coarse extrema the tiles' halos are bounded by.

A :class:`ReliefGrid` holds, for every ``block`` x ``block`` square of samples, the
largest and smallest finite height (float64, after any z factor; -inf / +inf for a
block of nodata only), and the map's overall extrema, from which it also gives the
base every tile's float32 heights are taken relative to (the very offset
:class:`~oclshade.heightmap.Heightmap` computes for the whole map).  It is built in
one pass over the map, from an array or from stripes of any rows streamed in order
(:meth:`ReliefGrid.accumulate`), 16 bytes a block: 256^2 blocks make a 32768^2 map's
grid 256 KiB.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

DEFAULT_BLOCK = 256


def _block_extrema(stripe: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """(max, min) of each ``block``-wide group of columns of a stripe (NaN ignored; -inf / +inf
    for a group of NaN only), without copying the stripe."""
    rows, cols = stripe.shape
    full = cols // block * block
    parts = [stripe[:, :full].reshape(rows, -1, block)] if full else []
    if full < cols:
        parts.append(stripe[:, full:].reshape(rows, 1, cols - full))
    hi = np.concatenate([np.fmax.reduce(np.fmax.reduce(p, axis=2), axis=0) for p in parts])
    lo = np.concatenate([np.fmin.reduce(np.fmin.reduce(p, axis=2), axis=0) for p in parts])
    return np.where(np.isnan(hi), -np.inf, hi), np.where(np.isnan(lo), np.inf, lo)


@dataclass
class ReliefGrid:
    """Block maxima and minima of a map's heights (see the module docstring)."""

    shape: tuple[int, int]               # the map's (rows, cols)
    block: int = DEFAULT_BLOCK           # samples per block side
    hi: np.ndarray = field(init=False, repr=False)   # (block rows, block cols) float64, -inf: no data
    lo: np.ndarray = field(init=False, repr=False)   # +inf: no data
    rows_done: int = field(init=False, default=0)
    #: (min, max) of the heights but an undeclared nodata sentinel's (heightmap.ordinary_extrema), where
    #: the pass that made the grid found them (tiles.stream.relief_pass): the map's scale takes them
    ordinary: tuple[float, float] | None = field(init=False, default=None, repr=False)

    def __post_init__(self) -> None:
        rows, cols = self.shape
        if rows < 1 or cols < 1:
            raise ValueError(f"shape must be positive (rows, cols), got {self.shape!r}")
        if isinstance(self.block, bool) or not isinstance(self.block, int) or self.block < 1:
            raise ValueError(f"block must be a positive integer, got {self.block!r}")
        grid = (-(-rows // self.block), -(-cols // self.block))
        self.hi = np.full(grid, -np.inf)
        self.lo = np.full(grid, np.inf)

    @classmethod
    def of(cls, heights: np.ndarray, block: int = DEFAULT_BLOCK) -> "ReliefGrid":
        """The grid of a whole (rows, cols) float64 array (NaN = nodata)."""
        grid = cls(tuple(heights.shape), block)
        for r in range(0, heights.shape[0], block):
            grid.accumulate(heights[r:r + block])
        return grid

    @classmethod
    def from_extrema(cls, shape: tuple[int, int], block: int, hi: np.ndarray, lo: np.ndarray) -> "ReliefGrid":
        """A grid from block maxima and minima computed elsewhere (e.g. per chunk by Dask)."""
        grid = cls(tuple(shape), block)
        if hi.shape != grid.hi.shape or lo.shape != grid.lo.shape:
            raise ValueError(f"block extrema of shape {hi.shape} do not fit a {shape} map in blocks of {block}")
        grid.hi, grid.lo, grid.rows_done = np.asarray(hi, np.float64), np.asarray(lo, np.float64), shape[0]
        return grid

    @staticmethod
    def extrema_of(heights: np.ndarray, block: int) -> np.ndarray:
        """(block rows, block cols, 2) maxima and minima of a chunk whose origin is on the block grid."""
        grid = ReliefGrid.of(heights, block)
        return np.stack([grid.hi, grid.lo], axis=-1)

    def accumulate(self, stripe: np.ndarray) -> None:
        """Add the next rows of the map (float64 heights, NaN = nodata), in order from row 0."""
        rows, cols = self.shape
        n = stripe.shape[0]
        if stripe.ndim != 2 or stripe.shape[1] != cols or self.rows_done + n > rows:
            raise ValueError(f"stripe of shape {stripe.shape} does not continue a {rows}x{cols} map at row "
                             f"{self.rows_done}")
        b, r = self.block, 0
        while r < n:                                   # split at the blocks' row boundaries
            k = (self.rows_done + r) // b
            end = min(n, (k + 1) * b - self.rows_done)
            hi, lo = _block_extrema(stripe[r:end], b)
            self.hi[k] = np.maximum(self.hi[k], hi)
            self.lo[k] = np.minimum(self.lo[k], lo)
            r = end
        self.rows_done += n

    @property
    def complete(self) -> bool:
        return self.rows_done == self.shape[0]

    @property
    def extrema(self) -> tuple[float, float]:
        """(min, max) of the map's finite heights; (nan, nan) when it has none."""
        lo, hi = float(self.lo.min()), float(self.hi.max())
        return (lo, hi) if math.isfinite(lo) else (math.nan, math.nan)

    @property
    def base(self) -> float:
        """The offset of the whole map's float32 relative heights: Heightmap.offset, the
        midpoint of the extrema computed as it does (0 for a map of nodata only)."""
        lo, hi = self.extrema
        return 0.0 if math.isnan(lo) else 0.5 * lo + 0.5 * hi

    def region(self, r0: int, r1: int, c0: int, c1: int) -> tuple[float, float]:
        """(min, max) over the blocks holding samples [r0, r1) x [c0, c1) (clipped to the map):
        bounds of the heights there; (inf, -inf) when the region is empty or all nodata."""
        rows, cols = self.shape
        r0, c0 = max(r0, 0), max(c0, 0)
        r1, c1 = min(r1, rows), min(c1, cols)
        if r0 >= r1 or c0 >= c1:
            return math.inf, -math.inf
        b = self.block
        sl = (slice(r0 // b, -(-r1 // b)), slice(c0 // b, -(-c1 // b)))
        return float(self.lo[sl].min()), float(self.hi[sl].max())
