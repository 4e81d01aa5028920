"""A geographic grid's scale: its cells are metres at the centre latitude's scale (oclshade.io),
so a row's true cell width differs from the grid's; what traces each band of rows with its own
(docs/methods.md, "Geographic grids")."""
from __future__ import annotations

import math

import numpy as np

from ..heightmap import check_row_scales

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


def scale_bands(rows: int, row_scales: np.ndarray | None, tolerance: float = SCALE_TOLERANCE
                ) -> tuple[np.ndarray, np.ndarray]:
    """(edges, scales): bands of rows [edges[k], edges[k + 1]) and float64 (bands, 2), each band's
    (east, north) scale, the middle of its rows' (``row_scales``: float64 (rows, 2), the true
    metres east and north of one grid metre at each row, :meth:`oclshade.solar.MapPlaces.row_scales`;
    None: one band of scale 1).  A row's cell sizes differ from its band's by a share d of at
    most sqrt(2) tolerance (radians): a direction then turns by at most d / 2 (sin a cos a d)
    and an elevation angle moves by at most d / 2 (sin e cos e d), together at most the
    tolerance.  Bands are the most rows that hold it, in multiples of :data:`SCALE_ALIGN` where
    that many do (a fine grid), any number where not (coarse cells near the poles: down to one
    row).  (Rows near enough to 1 to be traced as they are come as 1:
    :meth:`oclshade.solar.MapPlaces.row_scales`.)"""
    if row_scales is None:
        return np.array([0, rows]), np.ones((1, 2))
    scales = check_row_scales(row_scales, rows)
    share = scale_share(tolerance)

    def holds(lo: np.ndarray, hi: np.ndarray) -> bool:
        return bool(np.all(hi - lo <= share * (hi + lo) / 2.0))

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
