"""Float64 reference of horizon angles (kernels/horizon.cl) and of the sky-view factor.

Horizon.  The ray of cell (i, j) at azimuth ``az`` is shadow.cl's sun ray
with elevation 0: ``x = j + ux t``, ``y = i + uy t``, t the horizontal
distance in metres, (ux, uy) from :meth:`oclshade.Sun.ray` (rounded to
float32, so both sides trace the very same ray).  Its horizon tangent is

    T = sup_{t > 0} (S(t) - z0 - c t^2) / t

over the valid bilinear surface S inside the map (the shadow walk's surface:
patches, grid-line profiles for rays along a grid line, corner samples at
corner passes out of holes), z0 the cell's height and c = (1 - k) / (2 R)
the curvature drop per square metre (0: a flat Earth).  The horizon angle is
atan(T) in degrees; -90 when the ray sees no surface at all (it leaves the
map at once or crosses only holes), NaN at nodata cells.  Without curvature
T - tan(e) is :func:`cast_shadows`' margin for a sun at elevation e, so a
cell is in cast shadow at (az, e) iff T > tan(e).

Search radius.  With ``max_distance`` R (metres, as r.horizon's
``maxdistance``, WhiteboxTools' ``max_dist``, RVT's radius in cells times the
cell size) the sup is over 0 < t <= R: the surface seen within R of the cell
along the ray, the last patch cut at t = R.

The walk is plain: every patch the ray crosses, each tested in closed form
(f(t) / t with f quadratic has its maximum at an end or at the tangent point,
:func:`~oclshade.reference.shadows._segment_margin`); it stops where no
terrain can be higher, ``(max height - z0) - c t^2 <= T t``.

Sky-view factor from N horizons h_i (degrees, azimuths 360 i / N), both over
a horizontal plane, horizons below it counted as 0 (the plane hides them):

* ``cosine``: the share of an isotropic sky's irradiance a horizontal surface
  receives, ``(1 / pi) \\int\\int_{h(phi)}^{pi/2} sin e cos e de dphi = 1 - mean sin^2 h``
  (the diffuse sky term of irradiance models; HORAYZON's horizontal-plane SVF);
* ``solid-angle``: the visible share of the hemisphere's solid angle,
  ``(1 / 2pi) \\int\\int_{h(phi)}^{pi/2} cos e de dphi = 1 - mean sin h``
  (Zaksek, Ostir & Kokalj 2011; RVT's sky_view_factor).
"""
from __future__ import annotations

import numpy as np

from ..heightmap import Heightmap
from ..solar.scale import SCALE_TOLERANCE, direction_factor, scale_blocks
from ..sun import Sun
from .shadows import CORNER_SNAP, FLOAT32_EPS, _patch_valid, _sample, _segment_margin, start_patches

SVF_DEFINITIONS = ("cosine", "solid-angle")


def horizon_tolerance(hm: Heightmap, curvature: float = 0.0) -> float:
    """Bound on |T_float32 - T| (tangent units) from the kernel's float32 arithmetic.

    A candidate value is (S - z0 - c t^2) / t: the heights, relative to the
    midpoint, carry a few ulps of the relief, the surface's position along the
    ray (measured from the cell) a few ulps of the distance, which moves S by
    slope x that; divided by t >= one cell this is eps x (relief / cell +
    steepest slope), and eps x c t for the curvature drop (t up to the map's
    diagonal).  A tile skipped by a rounded comparison, or a corner pass
    decided in float32, moves T by the same order.  Times a safety factor 64,
    as :func:`~oclshade.reference.tie_tolerance` (whose value at elevation 0
    is the first two terms).
    """
    h = hm.heights
    finite = h[np.isfinite(h)]
    if finite.size == 0:
        return 0.0
    relief = float(finite.max() - finite.min())
    d = min(hm.dx, hm.dy)
    slopes = [np.abs(np.diff(h, axis=a)) / step for a, step in ((1, hm.dx), (0, hm.dy)) if h.shape[a] > 1]
    slope = max((float(np.nanmax(s)) for s in slopes if np.isfinite(s).any()), default=0.0)
    diagonal = float(np.hypot(h.shape[0] * hm.dy, h.shape[1] * hm.dx))
    return 64.0 * FLOAT32_EPS * (relief / d + slope + curvature * diagonal)


def angle_tolerance(hm: Heightmap, curvature: float = 0.0) -> float:
    """Bound on |angle_float32 - angle| in degrees: the tangent's bound (atan has slope <= 1)
    plus the float32 atan and conversion to degrees (8 ulps of 90 degrees)."""
    return float(np.degrees(horizon_tolerance(hm, curvature))) + 8.0 * FLOAT32_EPS * 90.0


def horizon_tangents(hm: Heightmap, azimuth: float, curvature: float = 0.0,
                     cells: tuple[np.ndarray, np.ndarray] | None = None,
                     max_distance: float = np.inf) -> np.ndarray:
    """T of every cell (default) or of the cells ``(rows, cols)`` (1-D integer arrays), float64:
    shape (rows, cols) of the map, or of ``cells[0]``; -inf where the ray sees nothing, NaN at
    nodata.  ``curvature``: c per square metre (the kernel's float32 value, for an exact match);
    ``max_distance``: the search radius R in metres (the kernel's float32 value)."""
    h = hm.heights
    if cells is None:
        ii, jj = (a.ravel() for a in np.indices(h.shape))
        shape = h.shape
    else:
        ii, jj = (np.asarray(a, np.int64).ravel() for a in cells)
        shape = np.shape(cells[0])
    out = np.full(ii.shape, np.nan)
    ok = np.flatnonzero(~np.isnan(h[ii, jj]))
    out[ok] = _walk(hm, azimuth, curvature, ii[ok], jj[ok], float(max_distance))
    return out.reshape(shape)


def horizon_angles(hm: Heightmap, azimuth: float, curvature: float = 0.0,
                   cells: tuple[np.ndarray, np.ndarray] | None = None,
                   max_distance: float = np.inf) -> np.ndarray:
    """Horizon angles in degrees (float64) as :func:`horizon_tangents`: -90 where nothing is seen."""
    return np.degrees(np.arctan(horizon_tangents(hm, azimuth, curvature, cells, max_distance)))


def banded_horizon_angles(hm: Heightmap, azimuth: float, curvature: float = 0.0,
                          cells: tuple[np.ndarray, np.ndarray] | None = None,
                          max_distance: float = np.inf) -> np.ndarray:
    """:func:`horizon_angles` of a heightmap with :attr:`~oclshade.heightmap.Heightmap.row_scales`
    (a georeferenced raster's) as :class:`oclshade.horizon.HorizonCaster` traces it: each cell with
    the cell sizes of its block (:func:`oclshade.solar.scale.scale_blocks`: dx, dy times
    the block's scale, and a projected block's stretch at ``azimuth``,
    :func:`oclshade.solar.scale.direction_factor`), rays over the whole map.  Without row scales: :func:`horizon_angles`.
    (Every other reference takes the grid as drawn, dx by dy, and the suns as the grid traces
    them.)"""
    ii, jj = (a.ravel() for a in np.indices(hm.shape)) if cells is None else \
        (np.asarray(a, np.int64).ravel() for a in cells)
    blocks = scale_blocks(hm.shape, hm.row_scales, SCALE_TOLERANCE)
    a, b = blocks.block_of(ii, jj)
    across = blocks.scales.shape[1]
    which = a * across + b                                  # raster order
    out = np.empty(ii.shape)
    for k in np.unique(which):
        scales = blocks.scales[divmod(int(k), across)]
        stretch = float(direction_factor(scales, azimuth))       # a projected block's, that way (1: none)
        own = Heightmap(hm.heights, hm.dx * float(scales[0]) * stretch, hm.dy * float(scales[1]) * stretch)
        at = which == k
        out[at] = horizon_angles(own, azimuth, curvature, (ii[at], jj[at]), max_distance)
    return out.reshape(hm.shape if cells is None else np.shape(cells[0]))


def _walk(hm: Heightmap, azimuth: float, c: float, ii: np.ndarray, jj: np.ndarray,
          max_distance: float = np.inf) -> np.ndarray:
    """T of the valid cells (ii, jj), every ray advanced one patch per step (vectorised across rays)."""
    h = hm.heights
    hp, wp = hm.patch_shape
    ux, uy, _ = Sun(azimuth, 0.0).ray(hm.dx, hm.dy)
    gmax = float(np.nanmax(h))
    x0, y0, z0 = jj.astype(np.float64), ii.astype(np.float64), h[ii, jj]
    pr, pc = start_patches(hm, ux, uy, x0, y0)
    on_row, on_col = uy == 0, ux == 0 and uy != 0
    result = np.full(ii.size, -np.inf)
    idx = np.arange(ii.size)
    t = np.zeros(idx.size)
    best = np.full(idx.size, -np.inf)
    while idx.size:
        with np.errstate(invalid="ignore"):    # best = -inf at t = 0
            done = (t > 0) & (((gmax - z0) - c * t * t <= best * t) | (t >= max_distance))
        inside = (pr >= 0) & (pr < hp) & (pc >= 0) & (pc < wp) & ~done
        if not inside.all():
            result[idx[~inside]] = best[~inside]
            keep = np.flatnonzero(inside)
            idx, pr, pc, x0, y0, z0, t, best = (a[keep] for a in (idx, pr, pc, x0, y0, z0, t, best))
            if not idx.size:
                break
        with np.errstate(divide="ignore"):
            tx = np.full(idx.size, np.inf) if ux == 0 else ((pc + (ux > 0)) - x0) / ux
            ty = np.full(idx.size, np.inf) if uy == 0 else ((pr + (uy > 0)) - y0) / uy
        with np.errstate(invalid="ignore"):
            snap = np.abs(tx - ty) / np.maximum(tx, ty) <= CORNER_SNAP
        tx = np.where(snap, np.minimum(tx, ty), tx)
        ty = np.where(snap, tx, ty)
        t_out = np.minimum(tx, ty)
        t_end = np.minimum(t_out, max_distance)          # the search radius cuts the last patch
        fx, fy = x0 + ux * t - pc, y0 + uy * t - pr
        if on_row or on_col:     # the linear profile of the grid line the ray runs along
            a0, a1, f, u = ((_sample(h, _line(y0), pc), _sample(h, _line(y0), pc + 1), fx, ux) if on_row else
                            (_sample(h, pr, _line(x0)), _sample(h, pr + 1, _line(x0)), fy, uy))
            valid = ~(np.isnan(a0) | np.isnan(a1))
            s_a, s1, s2 = a0 + (a1 - a0) * f, (a1 - a0) * u, np.zeros(idx.size)
        else:
            h00, h01 = _sample(h, pr, pc), _sample(h, pr, pc + 1)
            h10, h11 = _sample(h, pr + 1, pc), _sample(h, pr + 1, pc + 1)
            valid = ~(np.isnan(h00) | np.isnan(h01) | np.isnan(h10) | np.isnan(h11))
            ex, ey, k = h01 - h00, h10 - h00, h00 - h01 - h10 + h11
            s_a = h00 + ex * fx + ey * fy + k * fx * fy
            s1 = (ex + k * fy) * ux + (ey + k * fx) * uy
            s2 = k * ux * uy
        # f(t + tau) = S - z0 - c (t + tau)^2 = f_a + a tau + b tau^2 on [0, t_out - t]
        seg = _segment_margin(s_a - z0 - c * t * t, s1 - 2.0 * c * t, s2 - c, t, t_end - t, t == 0)
        best = np.where(valid, np.maximum(best, seg), best)
        via_x, via_y = tx <= ty, ty <= tx
        if ux != 0 and uy != 0:
            # a corner pass out of a hole touches the corner sample when a side neighbour is valid
            vr, vc = pr + (uy > 0), pc + (ux > 0)
            sides = (_patch_valid(h, hp, wp, pr, pc + (1 if ux > 0 else -1)) |
                     _patch_valid(h, hp, wp, pr + (1 if uy > 0 else -1), pc))
            corner = via_x & via_y & ~valid & sides & (t_out <= max_distance)
            f_v = (_sample(h, vr, vc) - z0 - c * t_out * t_out) / t_out
            best = np.where(corner, np.maximum(best, np.nan_to_num(f_v, nan=-np.inf)), best)
        if ux != 0:
            pc = np.where(via_x, pc + (1 if ux > 0 else -1), pc)
        if uy != 0:
            pr = np.where(via_y, pr + (1 if uy > 0 else -1), pr)
        t = t_out
    return result


def _line(p: np.ndarray) -> np.ndarray:
    """The grid line (integer row or column) a ray along it starts on."""
    return p.astype(np.int64)


def sky_view_factor(horizons: np.ndarray, definition: str = "cosine", axis: int = 0) -> np.ndarray:
    """Sky-view factor (float64) from horizon angles in degrees along ``axis`` (equally spaced
    azimuths); see the module docstring for the two definitions.  NaN stays NaN."""
    if definition not in SVF_DEFINITIONS:
        raise ValueError(f"definition must be one of {', '.join(SVF_DEFINITIONS)}; got {definition!r}")
    s = np.sin(np.radians(np.maximum(np.asarray(horizons, np.float64), 0.0)))
    return 1.0 - np.mean(s * s if definition == "cosine" else s, axis=axis)
