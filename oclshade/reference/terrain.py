"""Float64 reference of the terrain ray caster (kernels/terrain.cl): walk every patch a ray crosses.

The surface is the one the kernel sees: the relative float32 heights
(``Heightmap.relative32``) taken exactly as float64 values, bilinear between
samples, no surface over a patch with a hole corner, nothing beyond the map;
on a sphere base the deviations stand on the paraboloid
``-(X^2 + Y^2) / (2 R)`` around the centre sample (see
:class:`oclshade.terrain.Heightfield`).

A *hit* is the first point of the visible segment ``near <= t <= far``
where the ray crosses the surface from above to below (``f(t) = 0`` and
``f'(t) < 0`` for ``f`` = ray height above the surface): back faces are culled,
so a camera below the terrain or inside a hole sees through the underside.
Per patch, ``f`` is a quadratic in ``t`` (bilinear along a line, plus the
paraboloid), solved in closed form; a ray above the surface at one patch's
exit and not above it at the next one's entry crosses on their shared edge
(the walk carries that state, so it is watertight without tolerances).

No pyramid, no levels: rays are walked patch by patch (Amanatides-Woo),
vectorised across rays.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera, heightmap_from_world


@dataclass
class ReferenceTerrain:
    """Per requested pixel (flat arrays of length N)."""

    hit: np.ndarray        # bool
    depth: np.ndarray      # float64 t = -z_view of the hit; +inf where empty
    position: np.ndarray   # (N, 3) view-space position; 0 where empty
    cell: np.ndarray       # (N, 2) int64 patch (row, col); -1 where empty
    uv: np.ndarray         # (N, 2) heightmap coordinates (u = col, v = row); 0 where empty
    normal: np.ndarray     # (N, 3) view-space unit normal; 0 where empty


def first_crossing(a: np.ndarray, b: np.ndarray, c: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Smallest tau in [0, length] with a + b tau + c tau^2 = 0 and derivative < 0; +inf if none."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        disc = b * b - 4.0 * a * c
        sq = np.sqrt(np.maximum(disc, 0.0))
        q = -0.5 * (b + np.where(b >= 0.0, sq, -sq))
        linear = c == 0.0
        r1 = np.where(linear, np.where(b != 0.0, -a / b, np.inf), q / c)
        r2 = np.where(linear, np.inf, np.where(q != 0.0, a / q, np.inf))
        best = np.full(a.shape, np.inf)
        for r in (r1, r2):
            ok = ((disc >= 0.0) | linear) & np.isfinite(r) & (r >= 0.0) & (r <= length) \
                & (b + 2.0 * c * r < 0.0)
            best = np.where(ok & (r < best), r, best)
    return best


def _clip(o: np.ndarray, d: np.ndarray, axes: tuple[int, ...], lo: tuple[float, ...], hi: tuple[float, ...],
          t0: np.ndarray, t1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[t0, t1] clipped to the slabs lo[k] <= (o + t d)[axes[k]] <= hi[k]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis, a, b in zip(axes, lo, hi):
            ok, dk = o[:, axis], d[:, axis]
            ta, tb = (a - ok) / dk, (b - ok) / dk
            inside = (ok >= a) & (ok <= b)
            t0 = np.where(dk == 0.0, np.where(inside, t0, np.inf), np.maximum(t0, np.minimum(ta, tb)))
            t1 = np.where(dk == 0.0, t1, np.minimum(t1, np.maximum(ta, tb)))
    return t0, t1


def cast_terrain(field, camera: Camera, rows: np.ndarray | None = None,
                 cols: np.ndarray | None = None) -> ReferenceTerrain:
    """Cast the rays of the given pixels (default all, row-major) against ``field``
    (an :class:`oclshade.terrain.Heightfield`)."""
    hm = field.heightmap
    if rows is None or cols is None:
        rows, cols = np.mgrid[0:camera.height, 0:camera.width]
    rows, cols = np.asarray(rows).reshape(-1), np.asarray(cols).reshape(-1)
    n = rows.size
    o_view, d_view = camera.view_rays(rows, cols)
    out = ReferenceTerrain(np.zeros(n, bool), np.full(n, np.inf), np.zeros((n, 3)), np.full((n, 2), -1),
                           np.zeros((n, 2)), np.zeros((n, 3)))
    H, W = hm.shape
    if H < 2 or W < 2 or n == 0:
        return out                                # no patch has an area: nothing to hit
    h = hm.relative32.astype(np.float64)
    hp, wp = H - 1, W - 1
    cv, cu = field.centre
    g = heightmap_from_world(hm, field.centre) @ np.linalg.inv(camera.view)
    o = o_view @ g[:3, :3].T + g[:3, 3]
    d = d_view @ g[:3, :3].T
    kx, ky = field.curvature * hm.dx ** 2, field.curvature * hm.dy ** 2
    finite = h[np.isfinite(h)]
    if finite.size == 0:
        return out
    t0 = np.full(n, float(camera.near))
    t1 = np.full(n, float(camera.far))
    t0, t1 = _clip(o, d, (0, 1), (-cu, -cv), (wp - cu, hp - cv), t0, t1)
    if field.curvature == 0.0:      # the height slab, with a margin: the clip only prunes
        margin = 1e-3 * (finite.max() - finite.min()) + 1e-6 * (1.0 + np.abs(finite).max())
        t0, t1 = _clip(o, d, (2,), (finite.min() - margin,), (finite.max() + margin,), t0, t1)
    active = np.nonzero(t0 <= t1)[0]
    o, d, t0, t1 = o[active], d[active], t0[active], t1[active]
    # Amanatides-Woo walk over patches
    p = o + t0[:, None] * d
    col = np.clip(np.floor(p[:, 0]).astype(np.int64) + cu, 0, wp - 1)
    row = np.clip(np.floor(p[:, 1]).astype(np.int64) + cv, 0, hp - 1)
    step = np.where(d[:, :2] > 0, 1, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(d[:, :2] != 0.0, 1.0 / d[:, :2], np.inf)
    t = t0.copy()
    hit_t = np.full(active.size, np.inf)
    above = np.zeros(active.size, bool)      # above the surface at the end of the walk so far
    hit_cell = np.zeros((active.size, 2), np.int64)
    live = np.arange(active.size)
    for _ in range(hp + wp + 4):
        if live.size == 0:
            break
        r, c = row[live], col[live]
        bound_u = (c - cu + (step[live, 0] > 0)).astype(np.float64)
        bound_v = (r - cv + (step[live, 1] > 0)).astype(np.float64)
        with np.errstate(invalid="ignore"):
            tu = np.where(np.isfinite(inv[live, 0]), (bound_u - o[live, 0]) * inv[live, 0], np.inf)
            tv = np.where(np.isfinite(inv[live, 1]), (bound_v - o[live, 1]) * inv[live, 1], np.inf)
        t_exit = np.minimum(np.minimum(tu, tv), t1[live])
        ta = t[live]
        tb = np.maximum(t_exit, ta)
        h00, h01 = h[r, c], h[r, c + 1]
        h10, h11 = h[r + 1, c], h[r + 1, c + 1]
        pa = o[live] + ta[:, None] * d[live]
        s, w = pa[:, 0] - (c - cu), pa[:, 1] - (r - cv)
        e = h00 - h01 - h10 + h11
        hu, hv = (h01 - h00) + e * w, (h10 - h00) + e * s
        dl = d[live]
        a = pa[:, 2] - (h00 + (h01 - h00) * s + (h10 - h00) * w + e * s * w) \
            + kx * pa[:, 0] ** 2 + ky * pa[:, 1] ** 2
        b = dl[:, 2] - (hu * dl[:, 0] + hv * dl[:, 1]) + 2.0 * (kx * pa[:, 0] * dl[:, 0] + ky * pa[:, 1] * dl[:, 1])
        cq = -e * dl[:, 0] * dl[:, 1] + kx * dl[:, 0] ** 2 + ky * dl[:, 1] ** 2
        length = tb - ta
        valid = np.isfinite(e)
        tau = first_crossing(np.where(valid, a, 1.0), b, cq, length)
        tau = np.where(above[live] & (a <= 0.0), 0.0, tau)         # crossed on the shared edge
        found = valid & np.isfinite(tau)
        above[live] = valid & (a + (b + cq * length) * length > 0.0)
        hit_t[live[found]] = ta[found] + tau[found]
        hit_cell[live[found]] = np.stack([r[found], c[found]], -1)
        # advance
        go_u = tu <= tv
        go_v = tv <= tu
        new_c = c + np.where(go_u, step[live, 0], 0)
        new_r = r + np.where(go_v, step[live, 1], 0)
        t[live] = tb
        col[live], row[live] = new_c, new_r
        alive = ~found & (t_exit < t1[live]) & (new_c >= 0) & (new_c < wp) & (new_r >= 0) & (new_r < hp)
        live = live[alive]
    got = np.isfinite(hit_t)
    idx = active[got]
    th = hit_t[got]
    out.hit[idx] = True
    out.depth[idx] = th
    out.position[idx] = o_view[idx] + th[:, None] * d_view[idx]
    out.cell[idx] = hit_cell[got]
    ph = o[got] + th[:, None] * d[got]
    r, c = hit_cell[got, 0], hit_cell[got, 1]
    s, w = ph[:, 0] - (c - cu), ph[:, 1] - (r - cv)
    out.uv[idx] = np.stack([c + s, r + w], -1)
    h00, h01, h10, h11 = h[r, c], h[r, c + 1], h[r + 1, c], h[r + 1, c + 1]
    e = h00 - h01 - h10 + h11
    hu = (h01 - h00) + e * w - 2.0 * kx * ph[:, 0]
    hv = (h10 - h00) + e * s - 2.0 * ky * ph[:, 1]
    n_world = np.stack([-hu / hm.dx, hv / hm.dy, np.ones_like(hu)], -1)
    n_view = n_world @ camera.rotation.T
    out.normal[idx] = n_view / np.linalg.norm(n_view, axis=1, keepdims=True)
    return out


def dilated_max_levels(hm) -> list[np.ndarray]:
    """The bisection's dilated max levels 0..L (kernels/terrain.cl, terrain_dilate), float32; the
    renderer builds and reads only its leaf level and up (``TerrainRenderer.leaf_level``).

    Texel (R, C) of level l bounds the surface over the level-l tiles (R..R+1, C..C+1) (clamped
    to the level): level 0 from per-patch maxima of the valid corners (-inf for all-hole
    patches), levels >= 1 from :func:`oclshade.reference.extrema_pyramid`'s maxima — a different
    route from the kernel's 3 x 3 sample windows at level 0.  Max only: bit-identical.
    """
    from .pyramid import extrema_pyramid, patch_corners

    corners = patch_corners(hm)
    patch_max = np.where(np.isnan(corners), -np.inf, corners).max(0).astype(np.float32)
    out = []
    for lev in [patch_max] + [e[..., 0] for e in extrema_pyramid(hm)]:
        p = np.concatenate([lev, lev[-1:]], 0)
        p = np.concatenate([p, p[:, -1:]], 1)         # clamped window: repeat the last row/col
        out.append(np.maximum(np.maximum(p[:-1, :-1], p[:-1, 1:]), np.maximum(p[1:, :-1], p[1:, 1:])))
    return out


def sample_slopes(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dh/du, dh/dv) at every sample of ``h`` (float64, NaN = hole): central differences,
    one-sided next to holes and at the map's edges, 0 along an axis with neither neighbour."""
    def along(a: np.ndarray) -> np.ndarray:                 # the slope along axis 1
        pad = np.pad(a, ((0, 0), (1, 1)), constant_values=np.nan)
        left, centre, right = pad[:, :-2], pad[:, 1:-1], pad[:, 2:]
        lok, rok = np.isfinite(left), np.isfinite(right)
        return np.where(lok & rok, 0.5 * (right - left), np.where(rok, right - centre,
                                                                   np.where(lok, centre - left, 0.0)))
    return along(h), along(h.T).T


def shading_normals(field, camera: Camera, uv: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Smooth shading normals (kernels/terrain.cl terrain_normals, "Shading normals"): view-space
    unit normals (..., 3) at heightmap coordinates ``uv`` (..., 2) where ``hit``, 0 elsewhere.
    Slopes of the samples (:func:`sample_slopes`) interpolated bilinearly over the patch
    floor(uv) (clamped to the map; samples of weight 0 and holes left out, the weights
    renormalised), plus the paraboloid's slope on a sphere."""
    hm = field.heightmap
    H, W = hm.shape
    out = np.zeros(hit.shape + (3,))
    if H < 2 or W < 2 or not hit.any():
        return out
    h = hm.relative32.astype(np.float64)
    gu_s, gv_s = sample_slopes(h)
    u, v = (np.asarray(uv, np.float64)[hit][:, k] for k in (0, 1))
    c = np.clip(np.floor(u).astype(np.int64), 0, W - 2)
    r = np.clip(np.floor(v).astype(np.int64), 0, H - 2)
    s, w = np.clip(u - c, 0.0, 1.0), np.clip(v - r, 0.0, 1.0)
    gu, gv, total = np.zeros(u.shape), np.zeros(u.shape), np.zeros(u.shape)
    for dr, dc, wt in ((0, 0, (1 - s) * (1 - w)), (0, 1, s * (1 - w)), (1, 0, (1 - s) * w), (1, 1, s * w)):
        use = (wt > 0.0) & np.isfinite(h[r + dr, c + dc])
        wt = np.where(use, wt, 0.0)
        gu += wt * np.where(use, gu_s[r + dr, c + dc], 0.0)
        gv += wt * np.where(use, gv_s[r + dr, c + dc], 0.0)
        total += wt
    some = total > 0.0
    gu, gv = np.where(some, gu / np.where(some, total, 1.0), 0.0), np.where(some, gv / np.where(some, total, 1.0), 0.0)
    cv, cu = field.centre
    k = field.curvature
    gu = gu - 2.0 * k * hm.dx ** 2 * (u - cu)
    gv = gv - 2.0 * k * hm.dy ** 2 * (v - cv)
    n_view = np.stack([-gu / hm.dx, gv / hm.dy, np.ones_like(gu)], -1) @ camera.rotation.T
    out[hit] = n_view / np.linalg.norm(n_view, axis=1, keepdims=True)
    return out
