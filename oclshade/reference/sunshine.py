"""Float64 twin of kernels/sunshine.cl: sunshine sums from the reference masks.

For each daylight sun (elevation > 0) with weight w seconds, a cell gets
direct sun when :func:`cast_shadows` leaves it lit and the sun is above its
tangent plane, v = s_z - g_x s_x + g_y s_y > 0 with the gradient of
:func:`surface_gradient` (the one shadow.cl's self output tests); its beam
incidence is cos i = v / sqrt(1 + g_x^2 + g_y^2).  A float32 device can only
decide a cell differently where the reference's cast decision is a tie
(:meth:`ReferenceShadows.ties`) or |v| is within :func:`facing_tolerance`;
such cells are marked in ``ties`` and tests count them apart.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..heightmap import Heightmap
from ..sun import Sun, SunField, true_directions
from .shadows import FLOAT32_EPS, cast_shadows, surface_gradient, tie_tolerance


@dataclass
class ReferenceSunshine:
    sun_seconds: np.ndarray   # float64 seconds of direct sun per cell; NaN = nodata
    cast_seconds: np.ndarray  # float64 daylight seconds in cast shadow; NaN = nodata
    beam_hours: np.ndarray    # float64 sum of cos(i) x hours over the direct-sun steps; NaN = nodata
    beam_bound: np.ndarray    # bound on a float32 device's error in beam_hours (see sunshine_sums)
    daylight_seconds: float | np.ndarray   # per cell when some sun field's sun is up on part of the map only
    ties: np.ndarray          # bool: some sun's decision at the cell is within float32 rounding

    @property
    def hours(self) -> np.ndarray:
        return self.sun_seconds / 3600.0

    @property
    def fraction(self) -> np.ndarray:
        day = np.broadcast_to(np.asarray(self.daylight_seconds, np.float64), self.cast_seconds.shape)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(day > 0, self.cast_seconds / np.where(day > 0, day, 1.0), np.nan)


def gradient_error(hm: Heightmap) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, bounds on the float32 kernel's error in (g_x, g_y).

    The kernel's heights are float32 relative to the mid-range, each within
    eps R / 4 of its value (R: the relief), so a difference of two carries
    eps R / 2 and a gradient component eps R / (2 d); the rounding of the
    difference, of the cell size and of the division add 2 eps |g|.  Along an
    axis without neighbours the component is an exact 0.  Bounds: eps (R / d
    + 2 |g|), twice the first term for safety.
    """
    h = hm.heights
    finite = h[np.isfinite(h)]
    relief = float(finite.max() - finite.min()) if finite.size else 0.0
    gx, gy, has_x, has_y = surface_gradient(hm)
    return (np.where(has_x, FLOAT32_EPS * (relief / hm.dx + 2.0 * np.abs(gx)), 0.0),
            np.where(has_y, FLOAT32_EPS * (relief / hm.dy + 2.0 * np.abs(gy)), 0.0))


def facing_tolerance(hm: Heightmap, sun: Sun) -> np.ndarray:
    """Per cell, a bound on |v| within which float32 arithmetic may flip the facing test:
    the gradient's error (:func:`gradient_error`) times |s_x|, |s_y|, the rounding of the sun
    vector's components (eps / 2 each) and of v's two products and two sums (eps (|s_z| +
    |g_x s_x| + |g_y s_y|) each), times a safety factor of 8."""
    gx, gy, _, _ = surface_gradient(hm)
    return _facing_tolerance(gx, gy, *gradient_error(hm), sun.vector())


def _facing_tolerance(gx: np.ndarray, gy: np.ndarray, ex: np.ndarray, ey: np.ndarray,
                      vector: Sequence[float]) -> np.ndarray:
    """:func:`facing_tolerance` from the gradient and its error bounds (of any cells) and the
    sun's vector."""
    sx, sy, sz = (abs(c) for c in vector)
    return 8.0 * (ex * sx + ey * sy + 2.0 * FLOAT32_EPS * (sz + np.abs(gx) * sx + np.abs(gy) * sy))


def _surface(hm: Heightmap) -> tuple[np.ndarray, ...]:
    """(gx, gy, |n|, the gradient's error bounds, their effect through |n|) of every cell."""
    gx, gy, _, _ = surface_gradient(hm)
    ex, ey = gradient_error(hm)
    return gx, gy, np.sqrt(1.0 + gx * gx + gy * gy), ex, ey, 8.0 * (np.abs(gx) * ex + np.abs(gy) * ey)


def sunshine_sums(hm: Heightmap, suns: Sequence[Sun | SunField], seconds: Sequence[int]) -> ReferenceSunshine:
    """Sums over the suns (weights in seconds, one per sun) as kernels/sunshine.cl, from
    :func:`cast_shadows`; suns at or below the horizon are skipped.  A sun field adds each
    block's cells with its own sun (blocks whose sun is down are skipped), and the daylight
    time is then per cell.

    ``beam_bound``: outside ties a float32 device's cos i = v / |n| is off by
    at most the facing tolerance (the error of v; dividing by |n| >= 1 only
    shrinks it), plus the gradient's error through |n| = sqrt(1 + g^2):
    cos i (g . dg) / |n|^2 <= |g_x| dg_x + |g_y| dg_y (times 8, as the
    tolerance), plus 4 eps relative (1 + g^2, sqrt, division, the product
    with the float32 hours); its Kahan sum by 2 eps of the sum of the terms
    plus O(n eps^2) (Kahan 1965), and the float32 result by eps / 2: in all at
    most the sum over the direct steps of hours x (those terms + 16 eps).
    """
    nodata = np.isnan(hm.heights)
    gx, gy, norm, ex, ey, through_norm = _surface(hm)
    sun_s, cast_s, beam, bound, day = (np.zeros(hm.shape) for _ in range(5))
    ties = np.zeros(hm.shape, bool)
    rows, cols = hm.shape
    fields = False
    for item, w in zip(suns, seconds, strict=True):
        if isinstance(item, SunField):
            item.check_shape(hm.shape)
            fields = fields or not item.uniform
            vectors, cells = true_directions(*item.angles, item.scales, hm.dx, hm.dy)
            parts = [(b.sun, np.s_[b.row0:b.row1, b.col0:b.col1], vectors[k], cells[k])
                     for k, b in enumerate(item.blocks)]
        else:
            parts = [(item, np.s_[0:rows, 0:cols], item.vector(), (hm.dx, hm.dy))]
        for sun, win, vector, cell in parts:
            if sun.elevation <= 0.0:
                continue
            ref = cast_shadows(hm, sun, win)
            if tuple(cell) == (hm.dx, hm.dy):
                g = gx[win], gy[win], norm[win], ex[win], ey[win], through_norm[win]
            else:                                  # a geographic block: its own cells on the ground
                g = _surface(Heightmap(hm.heights, float(cell[0]), float(cell[1])))
                g = tuple(a[win] for a in g)
            sx, sy, sz = vector
            v = sz - g[0] * sx + g[1] * sy
            cast = ref.mask == 1
            direct = (ref.mask == 0) & (v > 0.0)
            sun_s[win] += np.where(direct, w, 0.0)
            cast_s[win] += np.where(cast, w, 0.0)
            beam[win] += np.where(direct, (w / 3600.0) * v / g[2], 0.0)
            tolerance = _facing_tolerance(g[0], g[1], g[3], g[4], vector)   # the map's, on the window
            bound[win] += np.where(direct, (w / 3600.0) * (tolerance + g[5] + 16.0 * FLOAT32_EPS), 0.0)
            ties[win] |= ref.ties(tie_tolerance(hm, sun)) | (np.abs(v) <= tolerance)
            day[win] += w
    total = float(day.max()) if not fields else day
    return ReferenceSunshine(*(np.where(nodata, np.nan, a) for a in (sun_s, cast_s, beam, bound)), total,
                             ties & ~nodata)
