"""A grid's scale: a geographic grid's cells are metres at the centre latitude's scale
(oclshade.io), so a row's true cell width differs from the grid's, and a projected grid's metre
is 1 / k of the ground's; what traces each band of rows with its own (docs/methods.md,
"Geographic grids", "Projected grids").

A row's scales (:meth:`oclshade.solar.MapPlaces.row_scales`) are float64 (east, north) or
(east, north, p, q): the true metres of one grid metre along the grid's columns and rows, and,
on a projected grid that is not conformal (Albers, Lambert azimuthal equal-area, Web Mercator
on the ellipsoid), its stretch by direction: a grid metre along grid azimuth a is

    s(a) = s sqrt(1 + p cos 2a + q sin 2a)

true metres, s (east = north) the root mean square over the directions (p = q = 0: the same
every way, a conformal projection's k; p, q only with east = north)."""
from __future__ import annotations

import math

import numpy as np

from ..heightmap import check_row_scales
from ..sun import sincos_degrees

#: degrees: a geographic grid's bands of rows (:func:`scale_bands`) keep every row's directions
#: and angles within this of its band's (the horizons' default; the sun fields take their tolerance)
SCALE_TOLERANCE = 0.01
#: rows: the bands' edges are multiples of this where the tolerance allows
SCALE_ALIGN = 16


def scale_share(tolerance: float = SCALE_TOLERANCE) -> float:
    """The share by which cell sizes may differ from their band's (2 sqrt(2) tolerance in
    radians, :func:`scale_bands`); a map whose scales are all within half of it of 1 is traced
    as it is (:meth:`oclshade.solar.MapPlaces.row_scales`)."""
    return 2.0 * math.sqrt(2.0) * math.radians(tolerance)


def stretch_of(scales: np.ndarray, sin: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """sqrt(1 + p cos 2a + q sin 2a) of scales (..., 2 or 4) along grid azimuths a given by their
    sines and cosines (broadcast against ``scales[..., 0]``; cos 2a = cos^2 - sin^2, sin 2a =
    2 sin cos: no trigonometry of its own): how much longer a grid metre is that way than
    ``s``; exactly 1 where p = q = 0 (or there are no such columns)."""
    scales = np.asarray(scales, np.float64)
    if scales.shape[-1] == 2:
        return np.ones(np.broadcast_shapes(scales.shape[:-1], np.shape(sin)))
    return np.sqrt(1.0 + scales[..., 2] * (cos * cos - sin * sin) + scales[..., 3] * (2.0 * sin * cos))


def direction_factor(scales: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """:func:`stretch_of` at grid azimuths in degrees, through :func:`oclshade.sun.sincos_degrees`
    (the C library's sine and cosine: the rays' stretch, host/src/shadows.c
    ocls_direction_factor, bit for bit)."""
    return stretch_of(scales, *sincos_degrees(azimuth))


def scale_bands(rows: int, row_scales: np.ndarray | None, tolerance: float = SCALE_TOLERANCE
                ) -> tuple[np.ndarray, np.ndarray]:
    """(edges, scales): bands of rows [edges[k], edges[k + 1]) and float64 (bands, 2 or 4, as
    ``row_scales``), each band's scales, the middle of its rows' (``row_scales``: float64 (rows,
    2 or 4), the module docstring's, :meth:`oclshade.solar.MapPlaces.row_scales`; None: one band
    of scale 1).  A row's cell sizes in any direction differ from its band's by a share d of at
    most sqrt(2) tolerance (radians): a direction then turns by at most d / 2 (sin a cos a d)
    and an elevation angle moves by at most d / 2 (sin e cos e d), together at most the
    tolerance.  (With p, q: d is at most the east and north scales' share plus half of
    |(dp, dq)|, each the half of its range in the band.)  Bands are the most rows that hold it,
    in multiples of :data:`SCALE_ALIGN` where that many do (a fine grid), any number where not
    (coarse cells near the poles: down to one row).  (Rows near enough to 1 to be traced as they are come as 1:
    :meth:`oclshade.solar.MapPlaces.row_scales`.)"""
    if row_scales is None:
        return np.array([0, rows]), np.ones((1, 2))
    scales = check_row_scales(row_scales, rows)
    share = scale_share(tolerance)

    def holds(lo: np.ndarray, hi: np.ndarray) -> bool:
        # (hi - lo) / (hi + lo), the scales' share, plus the stretch's, at most half the share
        stretch = np.hypot(hi[2] - lo[2], hi[3] - lo[3]) / 4.0 if len(lo) == 4 else 0.0
        return bool(np.all(hi[:2] - lo[:2] + stretch * (hi[:2] + lo[:2]) <= share * (hi[:2] + lo[:2]) / 2.0))

    # each band from its first row, its rows' extremes kept as it grows (host/src/horizon.c: the same)
    edges, middles, r0 = [0], [], 0
    while r0 < rows:
        end = min(rows, r0 + SCALE_ALIGN)
        lo, hi = scales[r0:end].min(axis=0), scales[r0:end].max(axis=0)
        step, r1 = (SCALE_ALIGN, end) if holds(lo, hi) else (1, r0 + 1)
        if step == 1:
            lo = hi = scales[r0]
        while r1 < rows:
            stop = min(rows, r1 + step)
            wider_lo, wider_hi = np.minimum(lo, scales[r1:stop].min(axis=0)), np.maximum(hi, scales[r1:stop].max(axis=0))
            if not holds(wider_lo, wider_hi):
                break
            lo, hi, r1 = wider_lo, wider_hi, stop
        edges.append(r1)
        middles.append((lo + hi) / 2.0)
        r0 = r1
    return np.array(edges), np.array(middles)
