"""Scene analysis before traversal: prove that a sun casts no shadow without tracing a ray.

Cases (:meth:`SceneAnalysis.casts_nothing`):

* sun at or below the horizon: everything is shadowed; the kernel's mode 2
  writes that without traversal (unchanged, see kernels/shadow.cl);
* sun at the zenith, or above the *no-shadow bound* of the map for its
  azimuth: no cell is in cast shadow and none is self-shadowed; the caster
  fills the outputs on the host, no kernel runs.

The no-shadow bound.  Along a ray from cell P the surface profile is
f(t) = S(P + t d) with f(0) = z0 (the ray starts on the surface); P is in
cast shadow iff f(t) > z0 + w t for some t > 0 (w = tan elevation).  On a
map without holes the profile is continuous, so f(t) - z0 <= G t where G is
the largest directional slope of the surface along the sun's azimuth, and
w > G rules shadow out everywhere.  On one bilinear patch the gradient in
cell units is (ex + k fy, ey + k fx), affine in (fx, fy), so the directional
slope grad . (ux, uy) (ux, uy in cells per metre, as the kernel's ray) is
affine and its maximum over the patch is at a corner.  The corner values pair
one x-edge difference (top or bottom) with one y-edge difference (left or
right), all four pairs occurring, so

    G = max over patches of  max(ux d_top, ux d_bottom) + max(uy d_left, uy d_right).

Grid-line rays (ux or uy = 0) see the edge differences alone, which this
covers.  The self-shadow flag uses central (or one-sided) differences at a
sample: their directional slope is an average of such corner pairs of the
patches around it, so it is <= G too and the flag is 0 wherever w > G.

Per map, :func:`slope_fronts` precomputes for each sign quadrant of (ux, uy)
the Pareto front of the points (|ux|-weight, |uy|-weight) over all patches
(O(N) with a pivot pre-filter, once, cached with the pyramid); per sun, G is a maximum over
the front (a few hundred points at most on real DEMs: microseconds).

Exactness: the skip must give what the float32 traversal gives.  The kernel
rounds; a sun within its rounding of G could be called shadowed by it.  The
skip therefore needs w > G + margin, margin = 128 eps32 (relief / min(dx, dy)
+ w + G_axis) with G_axis the steepest single edge slope: twice the formula
of :func:`oclshade.reference.tie_tolerance` (which bounds where float32 may
flip a decision), evaluated from cached per-map numbers of the float32
relative heights the kernel reads (the factor 2 absorbs their difference
from the float64 heights; tests check the margin is never the smaller).

Not covered, by decision:

* Maps with nodata holes, or a single row or column: the profile jumps
  across a hole (terrain resumes at any height after a gap that can be
  arbitrarily short when a ray clips a hole patch's corner), so no slope
  bound holds; they always trace.
* Per-ray reach relief / tan(elevation): the kernel already has it; every
  ray stops as soon as its entry height reaches the global maximum
  (``z_in >= z_top``), which is the same bound with the ray's own start
  height in place of the minimum.
* Per-tile skipping (tiles that can neither cast nor receive) needs the
  kernel to take a list of tiles or a per-tile flag (or one launch per
  surviving tile, whose overhead on PoCL eats the gain): a change to the ABI
  of kernels/shadow.cl, which is not this module's.  Head-room measured from
  the host (bench/skipping.py, 2 shared cores, PoCL 3.0): on the 1024^2
  canyon at sun 37/20 a full trace takes 349 ms, a launch that traces
  nothing 3 ms, and 88 % of the cells are lit (Jacksboro 344x403: 29 ms, 1.2
  ms, 94 %).  Lit cells still walk the pyramid until their ray clears the
  global maximum, so a sound per-tile proof (the no-shadow bound restricted
  to the patches within reach of the tile along the sun, relief / tan(e))
  could save much of that time: the most promising follow-up, for the
  kernel's owner.
"""
from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from .heightmap import Heightmap
from .sun import Sun

FLOAT32_EPS = float(np.finfo(np.float32).eps)
MARGIN_FACTOR = 128.0    # twice the reference tie tolerance (see the module docstring)
QUADRANTS = ((1, 1), (1, -1), (-1, 1), (-1, -1))


PIVOT_DIRECTIONS = 4
SAMPLE_ROWS = 16         # patch-row stride of SlopeFronts.sampled_slope
FRONT_BAND_CELLS = 1 << 16   # cells per band of the front computation (_fronts)
FRONT_BAND_BYTES = 96 * FRONT_BAND_CELLS   # its temporaries' bound (float64 copies, differences, sums)


def _pareto_front(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(k, 2) points of (x, y) not dominated in both coordinates (a superset of those that
    maximise a x + b y for some a, b >= 0).

    Pivots first: the maximisers of a x + b y for a few directions (a, b) >= 0
    are on the front; every point they dominate is dropped in O(N), which
    leaves few candidates for the sort.
    """
    keep = np.ones(x.shape, bool)
    for a in np.linspace(0.0, 0.5 * np.pi, PIVOT_DIRECTIONS):
        p = int(np.argmax(np.cos(a) * x + np.sin(a) * y))
        keep &= (x > x[p]) | (y > y[p])
        keep[p] = True
    xs, ys = x[keep], y[keep]
    order = np.argsort(xs, kind="stable")[::-1]
    ys_sorted = ys[order]
    prev = np.maximum.accumulate(np.concatenate([[-np.inf], ys_sorted[:-1]]))
    front = order[ys_sorted > prev]
    return np.stack([xs[front], ys[front]], axis=1)


def _fronts(h: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """The four quadrants' Pareto fronts of a (rows, cols) map's patches, computed over bands of
    about :data:`FRONT_BAND_CELLS` cells (bands share their edge row) and merged: the front of
    a union is the front of its parts' fronts, so the temporaries (about 80 bytes a cell, in
    float64) stay within a band; a tiled run under a memory budget counts on that."""
    rows, cols = h.shape
    step = max(1, FRONT_BAND_CELLS // max(1, cols))
    if rows <= step + 1:
        return _band_fronts(h.astype(np.float64))
    parts = [_band_fronts(h[r:min(r + step, rows - 1) + 1].astype(np.float64)) for r in range(0, rows - 1, step)]
    return {q: _pareto_front(*np.concatenate([part[q] for part in parts]).T) for q in QUADRANTS}


def _band_fronts(h: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    dxe, dye = np.diff(h, axis=1), np.diff(h, axis=0)
    top, bottom = dxe[:-1], dxe[1:]
    left, right = dye[:, :-1], dye[:, 1:]
    x_by_sign = {1: np.maximum(top, bottom).ravel(), -1: -np.minimum(top, bottom).ravel()}
    y_by_sign = {1: np.maximum(left, right).ravel(), -1: -np.minimum(left, right).ravel()}
    return {(sx, sy): _pareto_front(x_by_sign[sx], y_by_sign[sy]) for sx, sy in QUADRANTS}


def _patch_slope(h: np.ndarray, r: int, c: int, ux: float, uy: float) -> float:
    """Largest directional slope of patch (r, c) (cell units times ux, uy)."""
    h00, h01, h10, h11 = (float(v) for v in (h[r, c], h[r, c + 1], h[r + 1, c], h[r + 1, c + 1]))
    top, bottom, left, right = h01 - h00, h11 - h10, h10 - h00, h11 - h01
    return max(ux * top, ux * bottom) + max(uy * left, uy * right)


def _widened(hi: float, lo: float) -> tuple[float, float]:
    """(hi, lo) of float32 differences widened to bound the exact ones."""
    e = FLOAT32_EPS * max(abs(hi), abs(lo))
    return hi + e, lo - e


class SlopeFronts:
    """Per-map data of the no-shadow bound (see the module docstring), in three stages
    each computed on first need:

    * a sample: the slopes of every SAMPLE_ROWS-th patch row, whose maximum is a
      lower bound on G (a few ms on 4096^2: a low sun stops here, it cannot skip);
    * the edge extremes, O(N): an upper bound U (the separable bound |ux| max
      x-edge + |uy| max y-edge) and a lower bound L (the exact slope of the
      patches holding those extremes) on G, and the margin's numbers;
    * the Pareto fronts, for a sun with L < w <= U + margin, which needs G itself.
    """

    def __init__(self, h32: np.ndarray):
        self._h = h32                    # the kernel's float32 relative heights (read-only)
        self._fronts: dict[tuple[int, int], np.ndarray] | None = None

    def sampled_slope(self, ux: float, uy: float) -> float:
        """Largest directional slope of the patches in every SAMPLE_ROWS-th patch row: <= G."""
        h = self._h
        rows = np.arange(0, h.shape[0] - 1, SAMPLE_ROWS)
        top, bottom = np.diff(h[rows], axis=1), np.diff(h[rows + 1], axis=1)
        left, right = h[rows + 1, :-1] - h[rows, :-1], h[rows + 1, 1:] - h[rows, 1:]
        slope = np.maximum(ux * top, ux * bottom) + np.maximum(uy * left, uy * right)
        return float(slope.max())

    @cached_property
    def relief(self) -> float:
        return float(self._h.max()) - float(self._h.min())

    @cached_property
    def _extremes(self) -> tuple[tuple[float, float], tuple[float, float], list[tuple[int, int]]]:
        """(max, min) x-edge and y-edge differences, and the patches holding them."""
        h32 = self._h
        rows, cols = h32.shape
        # Edge differences in float32, one axis at a time into one scratch array (a
        # float64 copy of a 4096^2 map costs more than the whole shadow pass).  Each is
        # rounded by at most half an ulp of itself, so widening the extremes by eps32
        # times the largest magnitude keeps them bounds of the exact differences.
        scratch = np.empty(max(rows * (cols - 1), (rows - 1) * cols), np.float32)
        dxe = np.subtract(h32[:, 1:], h32[:, :-1], out=scratch[:rows * (cols - 1)].reshape(rows, cols - 1))
        ix = (np.unravel_index(int(np.argmax(dxe)), dxe.shape), np.unravel_index(int(np.argmin(dxe)), dxe.shape))
        x_ext = _widened(float(dxe[ix[0]]), float(dxe[ix[1]]))
        dye = np.subtract(h32[1:], h32[:-1], out=scratch[:(rows - 1) * cols].reshape(rows - 1, cols))
        iy = (np.unravel_index(int(np.argmax(dye)), dye.shape), np.unravel_index(int(np.argmin(dye)), dye.shape))
        y_ext = _widened(float(dye[iy[0]]), float(dye[iy[1]]))
        # patches holding the extreme edges (an x-edge (r, c) is in patches (r-1, c), (r, c))
        probe = sorted({(min(r, rows - 2), c) for r, c in ix} | {(r, min(c, cols - 2)) for r, c in iy})
        return x_ext, y_ext, probe

    @property
    def axis_step(self) -> tuple[float, float]:
        """The largest |x-edge| and |y-edge| difference."""
        x_ext, y_ext, _ = self._extremes
        return max(abs(v) for v in x_ext), max(abs(v) for v in y_ext)

    @property
    def nbytes(self) -> int:
        return self._h.nbytes + (sum(f.nbytes for f in self._fronts.values()) if self._fronts else 0)

    @property
    def fronts(self) -> dict[tuple[int, int], np.ndarray]:
        """(sign ux, sign uy) -> (k, 2) Pareto front of the patches' (x, y) corner weights."""
        if self._fronts is None:
            self._fronts = _fronts(self._h)
        return self._fronts

    def slope_bounds(self, ux: float, uy: float) -> tuple[float, float]:
        """(L, U) with L <= G <= U, in O(1)."""
        x_ext, y_ext, probe = self._extremes
        lower = max(_patch_slope(self._h, r, c, ux, uy) for r, c in probe)
        upper = (ux * x_ext[0] if ux >= 0 else ux * x_ext[1]) + (uy * y_ext[0] if uy >= 0 else uy * y_ext[1])
        return lower, upper

    def steepest_slope(self, ux: float, uy: float) -> float:
        """G: the largest directional slope (height per metre) of the bilinear surface along
        the horizontal direction (ux, uy) (cells per metre)."""
        front = self.fronts[(1 if ux >= 0 else -1, 1 if uy >= 0 else -1)]
        return float(np.max(abs(ux) * front[:, 0] + abs(uy) * front[:, 1]))


def slope_fronts(hm: Heightmap) -> SlopeFronts | None:
    """The per-map data of the bound, or None where no bound holds (holes, one row or column)."""
    h = hm.relative32
    if min(h.shape) < 2 or np.isnan(h.max()):     # NaN propagates through max; inf is never stored
        return None
    return SlopeFronts(h)


class SceneAnalysis:
    """What a sun needs over one heightmap, decided before any traversal."""

    def __init__(self, hm: Heightmap, fronts: SlopeFronts | None):
        self.heightmap = hm
        self.fronts = fronts

    def no_shadow_bound(self, sun: Sun) -> float:
        """tan(elevation) above which (strictly) the sun's azimuth casts no shadow and the
        traversal is skipped: G + margin; inf where no bound is known."""
        if self.fronts is None:
            return math.inf
        hm = self.heightmap
        ux, uy, w = sun.ray(hm.dx, hm.dy)
        return self.fronts.steepest_slope(ux, uy) + self.margin(w)

    def margin(self, w: float) -> float:
        """Float32 rounding margin of the kernel's decisions (see the module docstring)."""
        hm, f = self.heightmap, self.fronts
        d = min(hm.dx, hm.dy)
        axis = max(f.axis_step[0] / hm.dx, f.axis_step[1] / hm.dy)
        return MARGIN_FACTOR * FLOAT32_EPS * (f.relief / d + (w if math.isfinite(w) else 0.0) + axis)

    def casts_nothing(self, sun: Sun) -> bool:
        """True when no cell can be in cast shadow nor self-shadowed and the map has no
        holes: the outputs are known without a kernel (mask 0, self 0, coefficient 1)."""
        if self.fronts is None or sun.below_horizon:
            return False
        if sun.at_zenith:
            return True
        ux, uy, w = sun.ray(self.heightmap.dx, self.heightmap.dy)
        if w <= self.fronts.sampled_slope(ux, uy):      # <= G: no skip (the margin only adds)
            return False
        lower, upper = self.fronts.slope_bounds(ux, uy)
        margin = self.margin(w)
        if w <= lower + margin:         # G + margin >= w: no skip, and no need for G itself
            return False
        if w > upper + margin:          # U >= G
            return True
        return w > self.no_shadow_bound(sun)
