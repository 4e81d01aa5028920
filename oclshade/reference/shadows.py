"""Float64 numpy references of the kernels: the definitions the tests hold them to.

These are deliberately plain: no pyramid, no levels; every ray walks every
patch it crosses (vectorised across rays, not along them) and tests the
bilinear surface in closed form.

Shadow margin.  Besides the boolean mask, :func:`cast_shadows` returns for
each cell the *margin* ``m = sup_{t>0} (S(t) - z(t)) / t``: the tangent of
the terrain's elevation angle above the ray, as seen from the cell, along the
sun's azimuth (``tan(horizon) - tan(sun elevation)``).  The cell is in cast
shadow iff ``m > 0``.  A float32 kernel can only disagree with the reference
where ``|m|`` is within its rounding, :func:`tie_tolerance`; such cells are
*ties* and tests count them apart.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..heightmap import Heightmap
from ..sun import Sun, SunField

if TYPE_CHECKING:
    from .screen_shadows import Rounding

FLOAT32_EPS = float(np.finfo(np.float32).eps)
CORNER_SNAP = 1e-12   # relative gap |tx - ty| / t under which a ray passes through a corner
CORNER_TIE = 1e-5     # up to this gap a float32 kernel may see a corner pass: counted as a tie


@dataclass
class ReferenceShadows:
    mask: np.ndarray          # uint8 1/0/255 like the kernel
    margin: np.ndarray        # float64, see the module docstring; NaN at nodata
    self_shadow: np.ndarray   # uint8 1/0/255
    graze: np.ndarray         # bool: the ray passed within CORNER_TIE of a corner that could occlude

    def ties(self, tolerance: float) -> np.ndarray:
        """Cells a float32 kernel may decide either way: |margin| <= tolerance or a corner graze."""
        with np.errstate(invalid="ignore"):
            return (np.abs(self.margin) <= tolerance) | self.graze


def tie_tolerance(hm: Heightmap, sun: Sun, curvature: float = 0.0) -> float:
    """Bound on |margin| within which float32 arithmetic may flip the decision.

    The kernel's height differences carry an error of a few ulps of the
    relief, its ray heights a few ulps of w t (and of the curvature drop
    c t^2, t up to the map's diagonal); divided by t >= one cell this is
    eps * (relief / cell + w + steepest slope + c diagonal), times a safety factor.
    """
    h = hm.heights
    finite = h[np.isfinite(h)]
    if finite.size == 0:
        return 0.0
    relief = float(finite.max() - finite.min())
    d = min(hm.dx, hm.dy)
    _, _, w = sun.ray(hm.dx, hm.dy)
    steps = [np.abs(np.diff(h, axis=a)) / d for a, d in ((1, hm.dx), (0, hm.dy)) if h.shape[a] > 1]
    finite_steps = [s[np.isfinite(s)] for s in steps]
    slope = max((float(s.max()) for s in finite_steps if s.size), default=0.0)
    diagonal = float(np.hypot(h.shape[0] * hm.dy, h.shape[1] * hm.dx))
    return 64.0 * FLOAT32_EPS * (relief / d + (w if np.isfinite(w) else 0.0) + slope + curvature * diagonal)


def _sample(h: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    rows, cols = h.shape
    ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    out = np.full(r.shape, np.nan)
    out[ok] = h[r[ok], c[ok]]
    return out


def _segment_margin(f_a, a, b, t_in, length, first):
    """sup of f(t)/t over the segment, f(t_in + tau) = f_a + a tau + b tau^2."""
    t_out = t_in + length
    with np.errstate(divide="ignore", invalid="ignore"):
        at_in = np.where(first, a, f_a / np.where(first, 1.0, t_in))
        f_b = f_a + (a + b * length) * length
        at_out = np.where(first, a + b * length, f_b / t_out)
        best = np.maximum(at_in, at_out)
        # interior critical points of f(t)/t: b tau^2 + 2 b t_in tau + (a t_in - f_a) = 0
        disc = t_in * t_in - (a * t_in - f_a) / b
        ok = (~first) & (b != 0) & (disc >= 0)
        root = np.sqrt(np.where(ok, disc, 0.0))
        for tau in (-t_in + root, -t_in - root):
            inside = ok & (tau > 0) & (tau < length)
            val = (f_a + (a + b * tau) * tau) / (t_in + tau)
            best = np.where(inside, np.maximum(best, val), best)
    return best


def cast_shadows(hm: Heightmap, sun: Sun, window: tuple[slice, slice] | None = None,
                 curvature: float = 0.0) -> ReferenceShadows:
    """Float64 cast-shadow mask and margins of the cells in ``window`` (default all).

    Rays cross the whole map whatever the window.  Definitions as in
    kernels/shadow.cl; sun at or below the horizon: all shadowed; at the
    zenith: nothing cast.  ``curvature``: the Earth's drop per square metre
    (the kernel's float32 value, :attr:`oclshade.horizon.Curvature.coefficient`):
    the margin is then sup (S - z0 - w t - c t^2) / t.
    """
    h = hm.heights
    rows, cols = h.shape
    win = window or (slice(None), slice(None))
    ii, jj = np.meshgrid(np.arange(rows)[win[0]], np.arange(cols)[win[1]], indexing="ij")
    out_shape = ii.shape
    ii, jj = ii.ravel(), jj.ravel()
    z0 = h[ii, jj]
    margin = np.full(ii.shape, -np.inf)
    margin[np.isnan(z0)] = np.nan
    graze = np.zeros(ii.shape, bool)
    selfs = _self_shadow(hm, sun, ii, jj)
    if sun.below_horizon:
        margin[~np.isnan(z0)] = np.inf
    elif not sun.at_zenith:
        ok = np.flatnonzero(~np.isnan(z0))
        margin[ok], graze[ok] = walk_rays(hm, sun, jj[ok].astype(np.float64), ii[ok].astype(np.float64), z0[ok],
                                          curvature=curvature)
    mask = np.where(np.isnan(margin), 255, margin > 0).astype(np.uint8)
    return ReferenceShadows(mask.reshape(out_shape), margin.reshape(out_shape),
                            selfs.reshape(out_shape), graze.reshape(out_shape))


def cast_field_shadows(hm: Heightmap, field: SunField, curvature: float = 0.0) -> ReferenceShadows:
    """:func:`cast_shadows` of a sun that varies over the map: each block's cells with its own
    sun (rays still cross the whole map), as ``ShadowCaster`` traces a
    :class:`oclshade.sun.SunField`; ties: :func:`field_tie_tolerance`."""
    field.check_shape(hm.shape)
    rows, cols = hm.shape
    out = ReferenceShadows(np.zeros((rows, cols), np.uint8), np.zeros((rows, cols)), np.zeros((rows, cols), np.uint8),
                           np.zeros((rows, cols), bool))
    for block in field.blocks:
        window = (slice(block.row0, block.row1), slice(block.col0, block.col1))
        part = cast_shadows(hm, block.sun, window, curvature)
        for name in ("mask", "margin", "self_shadow", "graze"):
            getattr(out, name)[window] = getattr(part, name)
    return out


def field_tie_tolerance(hm: Heightmap, field: SunField, curvature: float = 0.0) -> float:
    """:func:`tie_tolerance` of the field's steepest block sun below the zenith (the bound grows
    with the ray's rise, which it leaves out at the zenith: that sun is evaluated too)."""
    below = [b.sun for b in field.blocks if b.sun.elevation < 90.0]
    zenith = [b.sun for b in field.blocks if b.sun.elevation >= 90.0]
    suns = ([max(below, key=lambda sun: sun.elevation)] if below else []) + zenith[:1]
    return max(tie_tolerance(hm, sun, curvature) for sun in suns)


def _patch_valid(h: np.ndarray, hp: int, wp: int, pr: np.ndarray, pc: np.ndarray) -> np.ndarray:
    inside = (pr >= 0) & (pr < hp) & (pc >= 0) & (pc < wp)
    corners = [_sample(h, pr + a, pc + b) for a in (0, 1) for b in (0, 1)]
    return inside & ~np.any(np.isnan(corners), axis=0)


def start_patches(hm: Heightmap, ux: float, uy: float, x0: np.ndarray,
                  y0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Patch (row, col) each ray enters from its origin (x0, y0) (kernel: start_patch):
    the patch containing it, or for an origin on a grid line the one on the ray's side."""
    hp, wp = hm.patch_shape
    fc, fr = np.floor(x0).astype(np.int64), np.floor(y0).astype(np.int64)
    pc = np.ceil(x0).astype(np.int64) - 1 if ux < 0 else (fc if ux > 0 else np.minimum(fc, wp - 1))
    pr = np.ceil(y0).astype(np.int64) - 1 if uy < 0 else (fr if uy > 0 else np.minimum(fr, hp - 1))
    return pr, pc


def walk_rays(hm: Heightmap, sun: Sun, x0: np.ndarray, y0: np.ndarray, z0: np.ndarray,
              heights: np.ndarray | None = None, curvature: float = 0.0,
              rounding: Rounding | None = None) -> tuple[np.ndarray, ...]:
    """Margins and corner grazes of sun rays from the surface points (x0, y0, z0).

    x0 (column) and y0 (row) are continuous sample coordinates, any real
    point of the map (integers for the cells themselves); z0 finite, the
    surface height there.  A ray that does not move along an axis and starts
    on a grid line of that axis sees the linear profile of that line (kernel:
    Ray.on_row / on_col).  ``heights``: the surface (default ``hm.heights``).
    ``curvature``: c per square metre, the Earth's drop of the terrain below
    the ray at distance t being c t^2 (the ray z0 + w t + c t^2 over the flat
    map; 0: a flat Earth).  Returns (margin, graze) as in
    :class:`ReferenceShadows`.

    ``rounding``: a bound of the float32 kernel's error per tested point
    (:class:`Rounding`); then also (margin_lo, margin_hi): the margins with every
    tested value of f = S - z lowered / raised by its bound.  A float32
    kernel says shadow only if margin_hi > 0 and lit only if margin_lo <= 0.
    """
    h = hm.heights if heights is None else heights
    hp, wp = hm.patch_shape
    ux, uy, w = sun.ray(hm.dx, hm.dy)
    c = float(curvature)
    gmax = np.nanmax(h)
    tol = tie_tolerance(hm, sun, c)
    n = x0.size
    margin = np.full(n, -np.inf)
    graze = np.zeros(n, bool)
    lo_out, hi_out = np.full(n, -np.inf), np.full(n, -np.inf)
    pr, pc = start_patches(hm, ux, uy, x0, y0)
    on_row = np.full(x0.shape, uy == 0) & (y0 == np.floor(y0))
    on_col = np.full(x0.shape, ux == 0) & (x0 == np.floor(x0)) & ~on_row
    line_r, line_c = y0.astype(np.int64), x0.astype(np.int64)   # used only on a line
    idx = np.arange(n)
    t = np.zeros(n)
    best = np.full(n, -np.inf)
    lo, hi = best.copy(), best.copy()
    carry = np.zeros(n)                  # rounding: error bound of f carried while near
    carried = np.ones(n, bool)           # ... and whether the kernel has a carried f
    sliver = np.zeros(n, bool)           # ... and whether this segment follows a near corner pass
    while idx.size:
        z_t = z0 + (w + c * t) * t       # the ray's height
        if rounding is None:
            going = (z_t < gmax) & (best <= tol)
        else:
            going = (z_t < gmax + rounding.top_error(idx, t, gmax)) & (lo <= 0)
        inside = (pr >= 0) & (pr < hp) & (pc >= 0) & (pc < wp) & going
        if not inside.all():
            done = ~inside
            margin[idx[done]], lo_out[idx[done]], hi_out[idx[done]] = best[done], lo[done], hi[done]
            keep = np.flatnonzero(inside)
            idx, pr, pc, x0, y0, z0, t, best, lo, hi, carry, carried, sliver, on_row, on_col, line_r, line_c = (
                a[keep] for a in (idx, pr, pc, x0, y0, z0, t, best, lo, hi, carry, carried, sliver, on_row, on_col,
                                  line_r, line_c))
            if not idx.size:
                break
            z_t = z_t[keep]
        with np.errstate(divide="ignore"):
            tx = np.full(idx.size, np.inf) if ux == 0 else ((pc + (ux > 0)) - x0) / ux
            ty = np.full(idx.size, np.inf) if uy == 0 else ((pr + (uy > 0)) - y0) / uy
        with np.errstate(invalid="ignore"):
            gap = np.abs(tx - ty) / np.maximum(tx, ty)
        snap = gap <= CORNER_SNAP
        tx = np.where(snap, np.minimum(tx, ty), tx)
        ty = np.where(snap, tx, ty)
        t_out = np.minimum(tx, ty)
        fx = x0 + ux * t - pc
        fy = y0 + uy * t - pr
        h00, h01 = _sample(h, pr, pc), _sample(h, pr, pc + 1)
        h10, h11 = _sample(h, pr + 1, pc), _sample(h, pr + 1, pc + 1)
        valid = ~(np.isnan(h00) | np.isnan(h01) | np.isnan(h10) | np.isnan(h11))
        ex, ey, k = h01 - h00, h10 - h00, h00 - h01 - h10 + h11
        s_a = h00 + ex * fx + ey * fy + k * fx * fy
        s1 = (ex + k * fy) * ux + (ey + k * fx) * uy
        s2 = k * ux * uy
        corner0 = h00
        spans = (np.maximum(np.abs(ex), np.abs(h11 - h10)), np.maximum(np.abs(ey), np.abs(h11 - h01)), np.abs(k))
        for line, axis, (a0, a1, f, u) in (
                (on_row, 0, (_sample(h, line_r, pc), _sample(h, line_r, pc + 1), fx, ux)),
                (on_col, 1, (_sample(h, pr, line_c), _sample(h, pr + 1, line_c), fy, uy))):
            if line.any():
                valid = np.where(line, ~(np.isnan(a0) | np.isnan(a1)), valid)
                s_a = np.where(line, a0 + (a1 - a0) * f, s_a)
                s1 = np.where(line, (a1 - a0) * u, s1)
                s2 = np.where(line, 0.0, s2)
                corner0 = np.where(line, a0, corner0)
                spans = tuple(np.where(line, np.abs(a1 - a0) if i == axis else 0.0, sp) for i, sp in enumerate(spans))
        # f(t + tau) = S - z0 - w (t + tau) - c (t + tau)^2 = f_a + a tau + b tau^2 on [0, t_out - t]
        f_a, a, b, length, first = s_a - z_t, s1 - w - 2.0 * c * t, s2 - c, t_out - t, t == 0
        seg = _segment_margin(f_a, a, b, t, length, first)
        best = np.where(valid, np.maximum(best, seg), best)
        if rounding is not None:
            e_first, e0, e1 = rounding.segment(idx, t, length, first, carry, carried, f_a, a, b, corner0, spans)
            seg_lo = np.where(first, seg - e_first, _segment_margin(f_a - e0, a - e1, b, t, length, first))
            seg_hi = np.where(first, seg + e_first, _segment_margin(f_a + e0, a + e1, b, t, length, first))
            # the segment after a near corner pass may be a sliver the kernel skips: no lower bound from it
            lo = np.where(valid & ~sliver, np.maximum(lo, seg_lo), lo)
            hi = np.where(valid, np.maximum(hi, seg_hi), hi)
            carry = np.where(first, length * e_first + rounding.u * np.abs(f_a + (a + b * length) * length),
                             e0 + e1 * length)
            carried = valid
        via_x, via_y = tx <= ty, ty <= tx
        if ux != 0 and uy != 0:
            # the corner the ray leaves by (or passes near) and its side neighbours
            vr, vc = pr + (uy > 0), pc + (ux > 0)
            z_out = z0 + (w + c * t_out) * t_out
            v = _sample(h, vr, vc)
            f_v = (v - z_out) / t_out
            sides = (_patch_valid(h, hp, wp, pr, pc + (1 if ux > 0 else -1)) |
                     _patch_valid(h, hp, wp, pr + (1 if uy > 0 else -1), pc))
            corner = via_x & via_y & ~valid & sides
            f_v0 = np.nan_to_num(f_v, nan=-np.inf)
            best = np.where(corner, np.maximum(best, f_v0), best)
            if rounding is None:
                near = (~snap) & (gap <= CORNER_TIE) & sides & (f_v > -tol)
            else:
                e_c = rounding.corner(idx, t_out, v) / t_out
                lo = np.where(corner, np.maximum(lo, f_v0 - e_c), lo)
                hi = np.where(corner, np.maximum(hi, f_v0 + e_c), hi)
                # a corner pass the kernel may decide otherwise: it may test a side patch's sliver
                # (up to the corner's f plus what the sliver adds) or skip the one walked here
                bound = f_v + e_c + rounding.sliver(t_out)
                near = (gap <= rounding.corner_gap) & sides & (bound > 0)
                hi = np.where(near, np.maximum(hi, bound), hi)
                sliver = near & ~snap
            graze[idx[near]] = True
        # step to the next patch (kernel: step_out at level 0)
        if ux != 0:
            pc = np.where(via_x, pc + (1 if ux > 0 else -1), pc)
        if uy != 0:
            pr = np.where(via_y, pr + (1 if uy > 0 else -1), pr)
        t = t_out
    if rounding is None:
        return margin, graze
    return margin, graze, lo_out, hi_out


def surface_gradient(hm: Heightmap) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(dz/d(east), dz/d(south)) per sample: central differences, one-sided next to holes
    and at the edges, 0 along an axis with neither neighbour (kernels/common.h ocls_gradient);
    and per axis whether a neighbour was there (where not, the gradient is an exact 0)."""
    return _gradient(hm.heights, hm.dx, hm.dy)


def _gradient(h: np.ndarray, dx: float, dy: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    pad = np.pad(h, 1, constant_values=np.nan)

    def along(plus: np.ndarray, minus: np.ndarray, d: float) -> tuple[np.ndarray, np.ndarray]:
        has_plus, has_minus = ~np.isnan(plus), ~np.isnan(minus)
        with np.errstate(invalid="ignore"):
            g = np.where(has_plus & has_minus, (plus - minus) / (2.0 * d),
                         np.where(has_plus, (plus - h) / d, np.where(has_minus, (h - minus) / d, 0.0)))
        return g, has_plus | has_minus

    gx, has_x = along(pad[1:-1, 2:], pad[1:-1, :-2], dx)
    gy, has_y = along(pad[2:, 1:-1], pad[:-2, 1:-1], dy)
    return gx, gy, has_x, has_y


def _self_shadow(hm: Heightmap, sun: Sun, ii: np.ndarray, jj: np.ndarray) -> np.ndarray:
    hc = hm.heights[ii, jj]
    if ii.size == 0:
        return hc.astype(np.uint8)
    rows, cols = hm.shape    # the gradient on the cells' bounding box grown by the one neighbour it reads
    r0, c0 = max(int(ii.min()) - 1, 0), max(int(jj.min()) - 1, 0)
    r1, c1 = min(int(ii.max()) + 2, rows), min(int(jj.max()) + 2, cols)
    gx, gy, _, _ = _gradient(hm.heights[r0:r1, c0:c1], hm.dx, hm.dy)
    gx, gy = gx[ii - r0, jj - c0], gy[ii - r0, jj - c0]
    sx, sy, sz = sun.vector()
    flag = (sz - gx * sx + gy * sy) <= 0
    if sun.below_horizon:
        flag[:] = True
    elif sun.at_zenith:
        flag[:] = False
    return np.where(np.isnan(hc), 255, flag).astype(np.uint8)


def shadow_coefficient(mask: np.ndarray, sun: Sun, k_dark: float, k_bright: float) -> np.ndarray:
    """Paper 000 eq. (1) with n = up: 1 lit, k_dark + (k_bright - k_dark) max(sin e, 0) shadowed."""
    dark = k_dark + (k_bright - k_dark) * max(sun.vector()[2], 0.0)
    return np.where(mask == 255, np.nan, np.where(mask == 1, dark, 1.0))
